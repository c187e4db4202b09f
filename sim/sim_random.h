#pragma once
/// @file
/// The simulator's only source of randomness: a seeded std::mt19937_64 with explicitly
/// implemented distributions (the standard library's distributions are implementation-defined),
/// so the same seed gives the same data bit for bit on every platform and build.

#include <cmath>
#include <cstdint>
#include <random>

namespace kestrel {

/// SplitMix64 finaliser: a bijective 64-bit mix, used to derive independent sub-seeds.
[[nodiscard]] inline uint64_t MixSeed(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Seeded generator with explicit uniform, Gaussian (polar method) and Bernoulli draws.
class SimRandom {
 public:
  /// A generator seeded with `seed` (std::mt19937_64's seeding).
  explicit SimRandom(uint64_t seed) : engine_(seed) {}

  /// 64 random bits.
  [[nodiscard]] uint64_t NextBits() { return engine_(); }
  /// Uniform in [0, 1) with 53 random bits.
  [[nodiscard]] double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  /// Standard normal N(0, 1) by Marsaglia's polar method (Box-Muller without trigonometry);
  /// the second value of each pair is kept for the next call.
  [[nodiscard]] double Gaussian() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double x, y, s;
    do {
      x = 2.0 * Uniform() - 1.0;
      y = 2.0 * Uniform() - 1.0;
      s = x * x + y * y;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = y * f;
    has_spare_ = true;
    return x * f;
  }
  /// True with probability p (p <= 0 never, p >= 1 always).
  [[nodiscard]] bool Bernoulli(double p) { return Uniform() < p; }

 private:
  std::mt19937_64 engine_;
  double spare_{0.0};
  bool has_spare_{false};
};

}  // namespace kestrel

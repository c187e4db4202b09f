#include "common/identity.h"

#include <mutex>
#include <random>

namespace kestrel {

namespace {

// SplitMix64's output function: a bijection of 64-bit words, so distinct inputs give distinct
// outputs.
uint64_t Mix(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

uint64_t RandomWord() {
  std::random_device device;
  return (static_cast<uint64_t>(device()) << 32) ^ static_cast<uint64_t>(device());
}

struct EpochSource {
  std::mutex mutex;
  bool started{false};
  uint64_t base{0};
  uint64_t count{0};
};

EpochSource& Source() {
  static EpochSource source;
  return source;
}

}  // namespace

int64_t NewPublisherEpoch() {
  EpochSource& s = Source();
  const std::lock_guard<std::mutex> lock(s.mutex);
  if (!s.started) {
    s.base = RandomWord();
    s.count = 0;
    s.started = true;
  }
  // base + k * (odd constant) takes 2^64 distinct values over k, and Mix is a bijection: the
  // draws of one process differ in all 64 bits; dropping the top bit keeps them positive. A
  // collision of the 63-bit values needs two 64-bit draws that differ only in their top bit.
  const uint64_t word = Mix(s.base + (s.count++) * 0x9e3779b97f4a7c15ULL);
  const auto epoch = static_cast<int64_t>(word & 0x7fffffffffffffffULL);
  return epoch == 0 ? 1 : epoch;
}

void SeedPublisherEpochs(uint64_t seed) {
  EpochSource& s = Source();
  const std::lock_guard<std::mutex> lock(s.mutex);
  s.base = Mix(seed ^ 0x6b657374726c4570ULL);  // "kestrlEp": seed 0 does not give base 0
  s.count = 0;
  s.started = true;
}

}  // namespace kestrel

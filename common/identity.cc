#include "common/identity.h"

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <mutex>
#include <random>
#include <stdexcept>

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

std::string NewRunId() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof(stamp), "%Y%m%dT%H%M%SZ", &utc);
  char random[16];
  std::snprintf(random, sizeof(random), "%08x", static_cast<unsigned>(RandomWord() & 0xffffffffu));
  return std::string(stamp) + "-" + random;
}

std::string CheckRunId(const std::string& run_id) {
  if (run_id.empty()) return "a run id is not empty";
  if (run_id.size() > 128) {
    return "a run id has at most 128 characters (this one has " + std::to_string(run_id.size()) +
           ")";
  }
  for (const char c : run_id) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == ':' || c == '+' || c == '-';
    if (!ok) return "a run id holds only A-Z a-z 0-9 . _ : + - (not '" + std::string(1, c) + "')";
  }
  return "";
}

std::string RunIdFromEnvironment() {
  const char* value = std::getenv(kRunIdEnvironmentVariable);
  if (value == nullptr || value[0] == '\0') return "";
  const std::string run_id = value;
  if (const std::string why = CheckRunId(run_id); !why.empty()) {
    throw std::invalid_argument(std::string("$") + kRunIdEnvironmentVariable + " = '" + run_id +
                                "': " + why);
  }
  return run_id;
}

std::string EnsureRunIdInEnvironment() {
  if (std::string run_id = RunIdFromEnvironment(); !run_id.empty()) return run_id;
  const std::string run_id = NewRunId();
  if (setenv(kRunIdEnvironmentVariable, run_id.c_str(), 1) != 0) {
    throw std::runtime_error(std::string("cannot set $") + kRunIdEnvironmentVariable);
  }
  return run_id;
}

}  // namespace kestrel

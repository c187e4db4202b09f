// The message contract and the one guarded decode path (common/lcm_decode.h).
#include "common/lcm_decode.h"

#include <chrono>
#include <cstdlib>
#include <random>

#include <gtest/gtest.h>

#include "lcmtypes/lcm_schemas.h"
#include "tests/lcmtypes/allocation_watch.h"
#include "tests/lcmtypes/sample_messages.h"

namespace kestrel {
namespace {

using testing::Encode;
using testing::MakeSample;

/// Runs `check` for every top-level type with a sample message.
template <typename Check>
struct ForAll {
  Check check;
  template <typename T>
  void Visit() {
    check(MakeSample<T>(3), T::getTypeName());
  }
};
template <typename Check>
void ForEveryType(Check check) {
  testing::ForEachMessageType(ForAll<Check>{check});
}

/// Writes a big-endian int32 at `offset`.
void PutInt32(std::vector<uint8_t>* bytes, size_t offset, int32_t v) {
  const auto u = static_cast<uint32_t>(v);
  for (int b = 0; b < 4; ++b) (*bytes)[offset + b] = static_cast<uint8_t>(u >> (24 - 8 * b));
}

// Every type round-trips with non-trivial content, through the guarded path.
TEST(LcmDecode, EveryTypeRoundTrips) {
  int visited = 0;
  ForEveryType([&](const auto& sample, const char* name) {
    using T = std::decay_t<decltype(sample)>;
    const std::vector<uint8_t> bytes = Encode(sample);
    T decoded;
    std::string error;
    ASSERT_TRUE(GuardedDecode(bytes.data(), bytes.size(), &decoded, &error))
        << name << ": " << error;
    EXPECT_EQ(Encode(decoded), bytes) << name;
    // A different sample encodes differently: the comparison above can fail.
    EXPECT_NE(Encode(MakeSample<T>(4)), bytes) << name;
    ++visited;
  });
  EXPECT_EQ(visited, testing::kNumMessageTypes);
}

// Every schema compiled into the build is a message the tests visit, or a nested type.
TEST(LcmDecode, EverySchemaIsCovered) {
  EXPECT_EQ(static_cast<int>(LcmSchemaSources().size()), testing::kNumMessageTypes + 5 + 7)
      << "+ nested: candidate, named value, procman command, param, map decision; + libbot2's "
         "seven "
         "bot_procman types (tests/common/procman_bot_procman_test.cc)";
}

// docs/design.md §3.1: utime (int64, us) is the first field of every message.
TEST(LcmDecode, UtimeIsTheFirstField) {
  ForEveryType([&](auto sample, const char* name) {
    sample.utime = 0x0102030405060708;
    const std::vector<uint8_t> bytes = Encode(sample);
    for (int b = 0; b < 8; ++b) EXPECT_EQ(bytes[8 + b], b + 1) << name;
  });
}

// Every strict prefix of a valid encoding is rejected, with a reason.
TEST(LcmDecode, TruncatedBuffersAreRejected) {
  ForEveryType([&](const auto& sample, const char* name) {
    using T = std::decay_t<decltype(sample)>;
    const std::vector<uint8_t> bytes = Encode(sample);
    for (size_t n = 0; n < bytes.size(); ++n) {
      T decoded;
      std::string error;
      EXPECT_FALSE(GuardedDecode(bytes.data(), n, &decoded, &error)) << name << " prefix " << n;
      EXPECT_FALSE(error.empty());
    }
  });
}

TEST(LcmDecode, TrailingBytesAndWrongTypeAreRejected) {
  std::vector<uint8_t> bytes = Encode(MakeSample<pose_t>(1));
  bytes.push_back(0);
  pose_t pose;
  std::string error;
  EXPECT_FALSE(GuardedDecode(bytes.data(), bytes.size(), &pose, &error));
  EXPECT_NE(error.find("trailing"), std::string::npos) << error;
  const std::vector<uint8_t> imu = Encode(MakeSample<imu_t>(1));
  EXPECT_FALSE(GuardedDecode(imu.data(), imu.size(), &pose, &error));
  EXPECT_NE(error.find("fingerprint"), std::string::npos) << error;
}

// A length field claiming 2^31-1 elements is refused before anything is allocated: instantly
// and with no allocation larger than a few KiB (lcm-gen's own decoder would resize first).
TEST(LcmDecode, HugeLengthIsRejectedBeforeAllocation) {
  const depth_image_t sample = MakeSample<depth_image_t>(1);
  std::vector<uint8_t> bytes = Encode(sample);
  // data_size is the int32 just before the data bytes at the end.
  const size_t data_size_offset = bytes.size() - sample.data.size() - 4;
  ASSERT_EQ(bytes[data_size_offset + 3], static_cast<uint8_t>(sample.data_size & 0xff));
  PutInt32(&bytes, data_size_offset, 0x7fffffff);
  depth_image_t decoded;
  std::string error;
  const auto start = std::chrono::steady_clock::now();
  bool ok = true;
  const size_t largest = testing::LargestAllocation(
      [&] { ok = GuardedDecode(bytes.data(), bytes.size(), &decoded, &error); });
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_FALSE(ok);
  EXPECT_NE(error.find("data"), std::string::npos) << error;
  EXPECT_LT(largest, 64u * 1024u) << "allocation during a rejected decode";
  EXPECT_LT(elapsed_s, 1.0);
  // Negative lengths too.
  PutInt32(&bytes, data_size_offset, -5);
  EXPECT_FALSE(GuardedDecode(bytes.data(), bytes.size(), &decoded, &error));
  EXPECT_NE(error.find("negative"), std::string::npos) << error;
}

// A string length of 0 (lcm-gen would assign length -1) or past the end is rejected.
TEST(LcmDecode, BadStringLengthsAreRejected) {
  std::vector<uint8_t> bytes = Encode(MakeSample<imu_t>(1));
  // imu_t: hash(8) utime(8) seq(8) epoch(8) then sensor_name's int32 length.
  for (const int32_t bad : {0, -1, 1 << 30}) {
    std::vector<uint8_t> copy = bytes;
    PutInt32(&copy, 32, bad);
    imu_t imu;
    std::string error;
    EXPECT_FALSE(GuardedDecode(copy.data(), copy.size(), &imu, &error)) << bad;
    EXPECT_NE(error.find("sensor_name"), std::string::npos) << error;
  }
}

// Random corruption of every type never crashes and never allocates more than the message.
TEST(LcmDecode, RandomCorruptionIsHandled) {
  std::mt19937_64 rng(42);
  ForEveryType([&](const auto& sample, const char* name) {
    using T = std::decay_t<decltype(sample)>;
    const std::vector<uint8_t> clean = Encode(sample);
    int rejected = 0;
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<uint8_t> bytes = clean;
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int f = 0; f < flips; ++f) {
        bytes[8 + rng() % (bytes.size() - 8)] = static_cast<uint8_t>(rng());
      }
      T decoded;
      std::string error;
      bool ok = true;
      const size_t largest = testing::LargestAllocation(
          [&] { ok = GuardedDecode(bytes.data(), bytes.size(), &decoded, &error); });
      EXPECT_LE(largest, bytes.size() * 8 + 4096) << name;
      if (!ok) ++rejected;
      if (ok) {
        EXPECT_EQ(Encode(decoded), bytes) << name << ": accepted bytes must round-trip";
      }
    }
    (void)rejected;
  });
}

}  // namespace
}  // namespace kestrel

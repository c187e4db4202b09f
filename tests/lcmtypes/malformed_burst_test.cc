// kestrel-fault's malformed messages (tools/fault/malformed.h, docs/design.md §7.11): every one
// is refused by the guarded decoder for the type of the channel's messages, every kind is made,
// and the burst is the same for the same seed.
#include "tools/fault/malformed.h"

#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/lcm_decode.h"
#include "tests/lcmtypes/sample_messages.h"

namespace kestrel {
namespace {

using testing::Encode;
using testing::MakeSample;

struct BurstChecker {
  int types{0};
  template <typename T>
  void Visit() {
    ++types;
    const std::string channel = std::string("TEST_") + T::getTypeName();
    const std::vector<uint8_t> sample = Encode(MakeSample<T>(3));
    EXPECT_EQ(KnownTypeOf(sample), T::getTypeName());
    const auto burst = MakeMalformedBurst(channel, sample, 40, 17);
    ASSERT_EQ(burst.size(), 40U) << channel;
    std::map<MalformedKind, int> kinds;
    for (const MalformedMessage& m : burst) {
      ++kinds[m.kind];
      std::string error;
      EXPECT_FALSE(
          CheckLcmBytes(T::getTypeName(), T::getHash(), m.bytes.data(), m.bytes.size(), &error))
          << channel << ": a " << MalformedKindName(m.kind) << " message passed";
      T decoded;
      EXPECT_FALSE(GuardedDecode(m.bytes.data(), m.bytes.size(), &decoded, &error));
    }
    // All four kinds; a type without a string or counted array (sim_truth_t) gets garbage in
    // place of the huge length.
    bool has_length = false;
    for (const LcmLengthField& f :
         LcmLengthFields(T::getTypeName(), T::getHash(), sample.data(), sample.size())) {
      has_length = has_length || f.width >= 4;
    }
    EXPECT_EQ(has_length, channel != "TEST_sim_truth_t") << channel;
    EXPECT_EQ(kinds[MalformedKind::kGarbage], has_length ? 10 : 20) << channel;
    EXPECT_EQ(kinds[MalformedKind::kTruncated], 10) << channel;
    EXPECT_EQ(kinds[MalformedKind::kBadFingerprint], 10) << channel;
    EXPECT_EQ(kinds[MalformedKind::kHugeLength], has_length ? 10 : 0) << channel;
    // The same seed gives the same bytes; another seed others.
    const auto again = MakeMalformedBurst(channel, sample, 40, 17);
    const auto other = MakeMalformedBurst(channel, sample, 40, 18);
    bool same = true, differs = false;
    for (size_t i = 0; i < burst.size(); ++i) {
      same = same && burst[i].bytes == again[i].bytes && burst[i].kind == again[i].kind;
      differs = differs || burst[i].bytes != other[i].bytes;
    }
    EXPECT_TRUE(same) << channel;
    EXPECT_TRUE(differs) << channel;
  }
};

TEST(MalformedBurst, EveryKindIsRefusedForEveryTypeAndReproducible) {
  BurstChecker checker;
  testing::ForEachMessageType(checker);
  EXPECT_EQ(checker.types, testing::kNumMessageTypes);
}

// With no message heard on a channel the burst is garbage only, refused as any type.
TEST(MalformedBurst, WithoutSampleOnlyGarbage) {
  const auto burst = MakeMalformedBurst("QUIET", {}, 12, 5);
  ASSERT_EQ(burst.size(), 12U);
  for (const MalformedMessage& m : burst) {
    EXPECT_EQ(m.kind, MalformedKind::kGarbage);
    EXPECT_GE(m.bytes.size(), 8U);
    std::string error;
    EXPECT_FALSE(
        CheckLcmBytes("pose_t", pose_t::getHash(), m.bytes.data(), m.bytes.size(), &error));
  }
  EXPECT_TRUE(KnownTypeOf({1, 2, 3}).empty());
}

// LcmLengthFields finds pose_t's first string length right after fingerprint, utime, seq, epoch,
// and a planar_scan_t's num_ranges before its ranges.
TEST(LcmLengthFields, FindsStringAndArrayLengths) {
  const std::vector<uint8_t> pose = Encode(MakeSample<pose_t>(1));
  const auto fields = LcmLengthFields("pose_t", pose_t::getHash(), pose.data(), pose.size());
  ASSERT_FALSE(fields.empty());
  EXPECT_EQ(fields[0].offset, 32U);
  EXPECT_EQ(fields[0].width, 4);
  EXPECT_TRUE(fields[0].is_string);
  planar_scan_t scan = MakeSample<planar_scan_t>(2);
  const std::vector<uint8_t> bytes = Encode(scan);
  bool found = false;
  for (const LcmLengthField& f :
       LcmLengthFields("planar_scan_t", planar_scan_t::getHash(), bytes.data(), bytes.size())) {
    if (f.is_string) continue;
    int64_t v = 0;
    for (int b = 0; b < f.width; ++b) v = (v << 8) | bytes[f.offset + static_cast<size_t>(b)];
    found = found || v == scan.num_ranges;
  }
  EXPECT_TRUE(found);
  std::vector<uint8_t> cut(pose.begin(), pose.end() - 1);
  EXPECT_TRUE(LcmLengthFields("pose_t", pose_t::getHash(), cut.data(), cut.size()).empty());
}

}  // namespace
}  // namespace kestrel

// The VN-100 protocol, pure (drivers/imu/vn100.h, docs/protocols.md §7).
#include "drivers/imu/vn100.h"

#include "drivers/imu/imu_node.h"

#include <gtest/gtest.h>

#include <cstring>

namespace kestrel {
namespace {

std::string Bytes(const std::vector<uint8_t>& v) { return std::string(v.begin(), v.end()); }

// CRC-16-CCITT with initial value 0 (XMODEM): the catalogue's check value of "123456789".
TEST(Vn100, CrcIsCcittWithZeroInitialValue) {
  const char* check = "123456789";
  EXPECT_EQ(Vn100Crc16(reinterpret_cast<const uint8_t*>(check), 9), 0x31C3);
}

// VectorNav's documented example: reading register 11 is "$VNRRG,11*73".
TEST(Vn100, AsciiChecksumMatchesTheManualsExample) {
  EXPECT_EQ(Vn100Command("RRG,11"), "$VNRRG,11*73\r\n");
  EXPECT_EQ(Vn100BinaryOutputBody(1, 2), "WRG,75,1,2,01,0121");
}

// The frame assembled by hand from the layout: sync, group 1, fields 0x0121 little endian,
// TimeStartup u64, AngularRate 3 float, Accel 3 float, CRC big endian.
TEST(Vn100, FrameBytesFollowTheLayout) {
  Vn100Sample s;
  s.time_startup_ns = 0x0102030405060708ULL;
  s.angular_rate_radps = {0.5F, -0.25F, 2.0F};
  s.accel_mps2 = {0.0F, 1.0F, -9.75F};
  std::vector<uint8_t> expected = {0xFA, 0x01, 0x21, 0x01, 0x08, 0x07,
                                   0x06, 0x05, 0x04, 0x03, 0x02, 0x01};
  for (const float v : {0.5F, -0.25F, 2.0F, 0.0F, 1.0F, -9.75F}) {
    uint8_t b[4];
    std::memcpy(b, &v, 4);
    expected.insert(expected.end(), b, b + 4);
  }
  const uint16_t crc = Vn100Crc16(expected.data() + 1, expected.size() - 1);
  expected.push_back(static_cast<uint8_t>(crc >> 8));
  expected.push_back(static_cast<uint8_t>(crc & 0xFF));
  const std::vector<uint8_t> frame = EncodeVn100Frame(s);
  EXPECT_EQ(frame, expected);
  EXPECT_EQ(frame.size(), 38u);
  EXPECT_EQ(Vn100Crc16(frame.data() + 1, frame.size() - 1), 0) << "CRC over the CRC is zero";
  EXPECT_EQ(Vn100CommonPayloadSize(kVn100KestrelFields), 32u);
  EXPECT_FALSE(Vn100CommonPayloadSize(0x8000).has_value());
}

TEST(Vn100, DeviceFrameToBodyNegatesYAndZ) {
  const std::array<double, 3> g = Vn100ToBody({0.0F, 0.0F, -9.81F});
  EXPECT_DOUBLE_EQ(g[2], 9.8100004196166992) << "level at rest: +g up in Kestrel's body";
  const std::array<double, 3> w = Vn100ToBody({0.5F, 0.25F, -2.0F});
  EXPECT_DOUBLE_EQ(w[0], 0.5);
  EXPECT_DOUBLE_EQ(w[1], -0.25);
  EXPECT_DOUBLE_EQ(w[2], 2.0);
}

// Garbage, a corrupted frame, a bad ASCII line and frames split across reads: every valid
// message is found, every drop counted once by reason.
TEST(Vn100Parser, ResynchronisesAndCountsEveryDrop) {
  Vn100Sample a, b;
  a.time_startup_ns = 1000;
  a.accel_mps2 = {0.0F, 0.0F, -9.8F};
  b.time_startup_ns = 2000;
  b.angular_rate_radps = {0.1F, 0.2F, 0.3F};
  std::string corrupt = Bytes(EncodeVn100Frame(a));
  corrupt[10] = static_cast<char>(corrupt[10] ^ 0x40);  // inside TimeStartup: no 0xFA, no '$'
  const std::string stream = std::string("\x01\x02\x03", 3) + Bytes(EncodeVn100Frame(a)) + corrupt +
                             "$VNWRG,75,1,2,01,0121*00\r\n" + Vn100Command("WRG,06,0") +
                             Bytes(EncodeVn100Frame(b));
  Vn100Parser parser;
  std::vector<Vn100Message> found;
  for (size_t at = 0; at < stream.size(); at += 7) {  // split across reads
    for (const Vn100Message& m : parser.Feed(std::string_view(stream).substr(at, 7))) {
      found.push_back(m);
    }
  }
  ASSERT_EQ(found.size(), 3u);
  EXPECT_EQ(found[0].kind, Vn100Message::Kind::kSample);
  EXPECT_EQ(found[0].sample.time_startup_ns, 1000u);
  EXPECT_FLOAT_EQ(found[0].sample.accel_mps2[2], -9.8F);
  EXPECT_EQ(found[1].kind, Vn100Message::Kind::kAscii);
  EXPECT_EQ(found[1].ascii, "VNWRG,06,0");
  EXPECT_EQ(found[2].sample.time_startup_ns, 2000u);
  EXPECT_FLOAT_EQ(found[2].sample.angular_rate_radps[1], 0.2F);
  EXPECT_EQ(parser.frames(), 2);
  EXPECT_EQ(parser.drops().at("bad_crc"), 1);
  EXPECT_EQ(parser.drops().at("bad_checksum"), 1);
  // The leading garbage, and the corrupted frame's bytes after its sync byte.
  EXPECT_EQ(parser.drops().at("garbage"), 2);
}

// A frame with more common fields than Kestrel's (YawPitchRoll between TimeStartup and
// AngularRate): Kestrel's fields are read at their offsets.
TEST(Vn100Parser, ReadsKestrelsFieldsAmongOthers) {
  std::vector<uint8_t> f = {0xFA, 0x01};
  const uint16_t fields = kVn100KestrelFields | (1u << 3);
  f.push_back(fields & 0xFF);
  f.push_back(fields >> 8);
  const auto put = [&](const void* p, size_t n) {
    const auto* b = static_cast<const uint8_t*>(p);
    f.insert(f.end(), b, b + n);
  };
  const uint64_t t = 77;
  put(&t, 8);
  const float ypr[3] = {10.0F, 20.0F, 30.0F}, rate[3] = {1.0F, 2.0F, 3.0F},
              accel[3] = {4.0F, 5.0F, 6.0F};
  put(ypr, 12);
  put(rate, 12);
  put(accel, 12);
  const uint16_t crc = Vn100Crc16(f.data() + 1, f.size() - 1);
  f.push_back(crc >> 8);
  f.push_back(crc & 0xFF);
  Vn100Parser parser;
  const auto found = parser.Feed(Bytes(f));
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].sample.time_startup_ns, 77u);
  EXPECT_EQ(found[0].sample.angular_rate_radps, (std::array<float, 3>{1.0F, 2.0F, 3.0F}));
  EXPECT_EQ(found[0].sample.accel_mps2, (std::array<float, 3>{4.0F, 5.0F, 6.0F}));
}

// The minimum-latency mapping: jittered arrivals give the device's spacing once the fastest
// path has been seen; a burst after a stall keeps them in order; a device restart starts anew.
TEST(MinimumLatencyClock, KeepsTheDeviceSpacingAndOrder) {
  MinimumLatencyClock clock(2000000);
  const int64_t offset = 1000000000;
  int64_t last = 0;
  for (int i = 0; i < 400; ++i) {
    const int64_t device = 5000000 + 2500 * i;
    const int64_t jitter = i == 3 ? 0 : 100 + (i * 7919) % 900;  // sample 3: the fast path
    const int64_t stamp = clock.Stamp(device, device + offset + jitter);
    ASSERT_GT(stamp, last) << i;
    if (i > 3) {
      ASSERT_EQ(stamp, device + offset) << i;
    }
    last = stamp;
  }
  // A burst: five samples read at once after a 20 ms stall.
  for (int k = 0; k < 5; ++k) {
    const int64_t device = 5000000 + 2500 * (400 + k);
    const int64_t stamp = clock.Stamp(device, 5000000 + 2500 * 404 + offset + 20000);
    ASSERT_EQ(stamp, device + offset) << "the stall does not move the stamps";
  }
  EXPECT_EQ(clock.restarts(), 0);
  EXPECT_EQ(clock.Stamp(1000, 2000000000), 2000000000 - 1000 + 1000) << "restarted";
  EXPECT_EQ(clock.restarts(), 1);
}

// The first sample came 10 ms late, the second on the fast path: the minimum falls by more than
// the spacing, and the second stamp is the first's + 1 us rather than earlier.
TEST(MinimumLatencyClock, NeverGoesBackWhenTheMinimumFalls) {
  MinimumLatencyClock clock(2000000);
  const int64_t first = clock.Stamp(5000000, 5000000 + 10000);
  const int64_t second = clock.Stamp(5002500, 5002500);
  EXPECT_EQ(first, 5010000);
  EXPECT_EQ(second, 5010001);
  EXPECT_EQ(clock.Stamp(5005000, 5005000 + 300), 5010002) << "still behind the first";
  EXPECT_EQ(clock.Stamp(5012500, 5012500 + 300), 5012500) << "the device pace again";
}

}  // namespace
}  // namespace kestrel

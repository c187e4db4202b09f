// The Vicon UDP object stream parser against datagrams built by hand, byte by byte, from the
// documented layout (docs/protocols.md §3.1), not with the encoder; the Euler convention against
// rotations computed by hand; every class of malformed datagram.
#include "drivers/vicon/vicon_packet.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

namespace kestrel {
namespace {

constexpr double kPi = 3.14159265358979323846;

// IEEE-754 doubles written out by hand (sign, exponent, mantissa), little-endian byte order:
// 1000.0 = 1.953125 * 2^9  -> 0x408F400000000000
// -2500.0 = -1.220703125 * 2^11 -> 0xC0A3880000000000
// 500.0 = 1.953125 * 2^8 -> 0x407F400000000000
// pi/2 = 0x3FF921FB54442D18, 0.25 = 0x3FD0000000000000, -0.5 = 0xBFE0000000000000
const std::vector<uint8_t> k1000 = {0x00, 0x00, 0x00, 0x00, 0x00, 0x40, 0x8f, 0x40};
const std::vector<uint8_t> kMinus2500 = {0x00, 0x00, 0x00, 0x00, 0x00, 0x88, 0xa3, 0xc0};
const std::vector<uint8_t> k500 = {0x00, 0x00, 0x00, 0x00, 0x00, 0x40, 0x7f, 0x40};
const std::vector<uint8_t> kHalfPi = {0x18, 0x2d, 0x44, 0x54, 0xfb, 0x21, 0xf9, 0x3f};
const std::vector<uint8_t> kQuarter = {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xd0, 0x3f};
const std::vector<uint8_t> kMinusHalf = {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0xbf};
const std::vector<uint8_t> kZero(8, 0x00);
const std::vector<uint8_t> kNaN = {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf8, 0x7f};
const std::vector<uint8_t> kInf = {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf0, 0x7f};

void Append(std::vector<uint8_t>* out, const std::vector<uint8_t>& bytes) {
  out->insert(out->end(), bytes.begin(), bytes.end());
}

// One object item: id 0, size 72 (0x48 0x00), a 24-byte name, then six doubles.
std::vector<uint8_t> HandItem(const std::string& name, const std::vector<uint8_t>& tx,
                              const std::vector<uint8_t>& ty, const std::vector<uint8_t>& tz,
                              const std::vector<uint8_t>& rx, const std::vector<uint8_t>& ry,
                              const std::vector<uint8_t>& rz) {
  std::vector<uint8_t> item = {0x00, 0x48, 0x00};
  for (size_t i = 0; i < 24; ++i) item.push_back(i < name.size() ? name[i] : 0x00);
  for (const auto* v : {&tx, &ty, &tz, &rx, &ry, &rz}) Append(&item, *v);
  return item;
}

// Frame 0x01020304 (bytes 04 03 02 01), two objects.
std::vector<uint8_t> HandDatagram() {
  std::vector<uint8_t> d = {0x04, 0x03, 0x02, 0x01, 0x02};
  Append(&d, HandItem("kestrel", k1000, kMinus2500, k500, kHalfPi, kZero, kZero));
  Append(&d, HandItem("wand", kZero, kZero, k1000, kQuarter, kMinusHalf, kHalfPi));
  return d;
}

ViconPacketError Parse(const std::vector<uint8_t>& d, ViconFrame* frame,
                       std::string* reason = nullptr, ViconParseOptions options = {}) {
  std::string ignored;
  return ParseViconDatagram(d.data(), d.size(), options, frame,
                            reason != nullptr ? reason : &ignored);
}

TEST(ViconPacket, ParsesHandBuiltDatagram) {
  const std::vector<uint8_t> d = HandDatagram();
  ASSERT_EQ(d.size(), 5u + 2u * 75u);
  ViconFrame frame;
  std::string reason;
  ASSERT_EQ(Parse(d, &frame, &reason), ViconPacketError::kNone) << reason;
  EXPECT_EQ(frame.frame_number, 0x01020304u);
  ASSERT_EQ(frame.objects.size(), 2u);
  EXPECT_EQ(frame.objects[0].name, "kestrel");
  EXPECT_EQ(frame.objects[0].translation_mm, Eigen::Vector3d(1000.0, -2500.0, 500.0));
  EXPECT_EQ(frame.objects[0].rotation_rad, Eigen::Vector3d(kPi / 2, 0.0, 0.0));
  EXPECT_EQ(frame.objects[1].name, "wand");
  EXPECT_EQ(frame.objects[1].translation_mm, Eigen::Vector3d(0.0, 0.0, 1000.0));
  EXPECT_EQ(frame.objects[1].rotation_rad, Eigen::Vector3d(0.25, -0.5, kPi / 2));
}

TEST(ViconPacket, EncoderReproducesHandBuiltBytes) {
  ViconFrame frame;
  frame.frame_number = 0x01020304u;
  frame.objects.push_back({"kestrel", {1000.0, -2500.0, 500.0}, {kPi / 2, 0.0, 0.0}});
  frame.objects.push_back({"wand", {0.0, 0.0, 1000.0}, {0.25, -0.5, kPi / 2}});
  EXPECT_EQ(EncodeViconDatagram(frame), HandDatagram());
}

TEST(ViconPacket, EmptyFrameIsValid) {
  ViconFrame frame;
  ASSERT_EQ(Parse({0x07, 0x00, 0x00, 0x00, 0x00}, &frame), ViconPacketError::kNone);
  EXPECT_EQ(frame.frame_number, 7u);
  EXPECT_TRUE(frame.objects.empty());
}

TEST(ViconPacket, NameOf23BytesIsAccepted) {
  std::vector<uint8_t> d = {0x01, 0x00, 0x00, 0x00, 0x01};
  Append(&d, HandItem(std::string(23, 'a'), kZero, kZero, kZero, kZero, kZero, kZero));
  ViconFrame frame;
  ASSERT_EQ(Parse(d, &frame), ViconPacketError::kNone);
  EXPECT_EQ(frame.objects[0].name, std::string(23, 'a'));
}

TEST(ViconPacket, ZeroPaddingAcceptedUnlessForbidden) {
  std::vector<uint8_t> d = HandDatagram();
  d.resize(512, 0x00);  // a reader's fixed 512-byte buffer
  ViconFrame frame;
  EXPECT_EQ(Parse(d, &frame), ViconPacketError::kNone);
  EXPECT_EQ(frame.objects.size(), 2u);
  ViconParseOptions strict;
  strict.allow_zero_padding = false;
  EXPECT_EQ(Parse(d, &frame, nullptr, strict), ViconPacketError::kTrailingBytes);
}

// Each malformation of the hand-built datagram, with the error it must give.
TEST(ViconPacket, RejectsEveryMalformation) {
  struct Case {
    const char* what;
    std::vector<uint8_t> bytes;
    ViconPacketError expected;
  };
  std::vector<Case> cases;
  const std::vector<uint8_t> good = HandDatagram();
  cases.push_back({"empty", {}, ViconPacketError::kTooShort});
  cases.push_back({"4 bytes", {0x01, 0x00, 0x00, 0x00}, ViconPacketError::kTooShort});
  {
    std::vector<uint8_t> d(good.begin(), good.end() - 1);  // one byte short of 2 items
    cases.push_back({"truncated item", d, ViconPacketError::kTooShort});
  }
  {
    std::vector<uint8_t> d = good;
    d[4] = 3;  // count says 3, bytes hold 2
    cases.push_back({"count above length", d, ViconPacketError::kTooShort});
  }
  {
    std::vector<uint8_t> d = good;
    d[4] = 1;  // count says 1, bytes hold 2 (non-zero trailing item)
    cases.push_back({"count below length", d, ViconPacketError::kTrailingBytes});
  }
  {
    std::vector<uint8_t> d = good;
    d[4] = 14;
    cases.push_back({"14 items", d, ViconPacketError::kTooManyItems});
  }
  {
    std::vector<uint8_t> d = good;
    d.resize(1025, 0x00);
    cases.push_back({"1025 bytes", d, ViconPacketError::kTooLong});
  }
  {
    std::vector<uint8_t> d = good;
    d[5 + 75] = 1;  // second item id 1
    cases.push_back({"item id 1", d, ViconPacketError::kUnknownItemId});
  }
  {
    std::vector<uint8_t> d = good;
    d[6] = 0x47;  // size 71
    cases.push_back({"item size 71", d, ViconPacketError::kBadItemSize});
  }
  {
    std::vector<uint8_t> d = good;
    d[7] = 0x01;  // size 0x0148 = 328: the high byte matters (little endian)
    cases.push_back({"item size 328", d, ViconPacketError::kBadItemSize});
  }
  {
    std::vector<uint8_t> d = {0x01, 0x00, 0x00, 0x00, 0x01};
    Append(&d, HandItem(std::string(24, 'a'), kZero, kZero, kZero, kZero, kZero, kZero));
    cases.push_back({"name without NUL", d, ViconPacketError::kBadName});
  }
  {
    std::vector<uint8_t> d = {0x01, 0x00, 0x00, 0x00, 0x01};
    Append(&d, HandItem("", kZero, kZero, kZero, kZero, kZero, kZero));
    cases.push_back({"empty name", d, ViconPacketError::kBadName});
  }
  {
    std::vector<uint8_t> d = {0x01, 0x00, 0x00, 0x00, 0x01};
    Append(&d, HandItem("ab\ncd", kZero, kZero, kZero, kZero, kZero, kZero));
    cases.push_back({"control byte in name", d, ViconPacketError::kBadName});
  }
  {
    std::vector<uint8_t> d = {0x01, 0x00, 0x00, 0x00, 0x02};
    Append(&d, HandItem("twin", kZero, kZero, kZero, kZero, kZero, kZero));
    Append(&d, HandItem("twin", k500, kZero, kZero, kZero, kZero, kZero));
    cases.push_back({"duplicate name", d, ViconPacketError::kDuplicateName});
  }
  for (int field = 0; field < 6; ++field) {
    for (const auto* bad : {&kNaN, &kInf}) {
      std::vector<uint8_t> d = good;
      std::copy(bad->begin(), bad->end(), d.begin() + 5 + 75 + 27 + 8 * field);
      cases.push_back({"non-finite value", d, ViconPacketError::kNonFinite});
    }
  }
  for (const Case& c : cases) {
    ViconFrame frame;
    std::string reason;
    EXPECT_EQ(Parse(c.bytes, &frame, &reason), c.expected)
        << c.what << ": got " << ViconPacketErrorName(Parse(c.bytes, &frame)) << " " << reason;
    EXPECT_EQ(reason.rfind(ViconPacketErrorName(c.expected), 0), 0u) << c.what << ": " << reason;
  }
}

TEST(ViconPacket, NullDataWithZeroSizeIsTooShort) {
  ViconFrame frame;
  std::string reason;
  EXPECT_EQ(ParseViconDatagram(nullptr, 0, {}, &frame, &reason), ViconPacketError::kTooShort);
}

// Property: encode random frames, parse them back bit-exactly (seeded generator).
TEST(ViconPacket, EncodeThenParseRoundTripsRandomFrames) {
  std::mt19937_64 rng(20261122);
  std::uniform_real_distribution<double> mm(-1e5, 1e5);
  std::uniform_real_distribution<double> rad(-kPi, kPi);
  std::uniform_int_distribution<int> count(0, static_cast<int>(kViconMaxItems));
  std::uniform_int_distribution<int> length(1, 23);
  std::uniform_int_distribution<int> letter(0x21, 0x7e);
  for (int trial = 0; trial < 500; ++trial) {
    ViconFrame frame;
    frame.frame_number = static_cast<uint32_t>(rng());
    const int n = count(rng);
    for (int k = 0; k < n; ++k) {
      ViconObject o;
      o.name = "o" + std::to_string(k) + "_";
      const int extra = length(rng) - static_cast<int>(o.name.size());
      for (int i = 0; i < extra; ++i) o.name.push_back(static_cast<char>(letter(rng)));
      o.translation_mm = {mm(rng), mm(rng), mm(rng)};
      o.rotation_rad = {rad(rng), rad(rng), rad(rng)};
      frame.objects.push_back(o);
    }
    const std::vector<uint8_t> bytes = EncodeViconDatagram(frame);
    ASSERT_LE(bytes.size(), kViconMaxDatagramBytes);
    ViconFrame parsed;
    std::string reason;
    ASSERT_EQ(Parse(bytes, &parsed, &reason), ViconPacketError::kNone) << reason;
    ASSERT_EQ(parsed.frame_number, frame.frame_number);
    ASSERT_EQ(parsed.objects.size(), frame.objects.size());
    for (size_t k = 0; k < frame.objects.size(); ++k) {
      EXPECT_EQ(parsed.objects[k].name, frame.objects[k].name);
      EXPECT_EQ(parsed.objects[k].translation_mm, frame.objects[k].translation_mm);
      EXPECT_EQ(parsed.objects[k].rotation_rad, frame.objects[k].rotation_rad);
    }
  }
}

TEST(ViconPacket, EncoderRejectsWhatTheWireCannotCarry) {
  ViconFrame frame;
  frame.objects.push_back({std::string(24, 'a'), {}, {}});
  EXPECT_THROW((void)EncodeViconDatagram(frame), std::invalid_argument);
  frame.objects[0] = {"ok", {std::nan(""), 0, 0}, {}};
  EXPECT_THROW((void)EncodeViconDatagram(frame), std::invalid_argument);
  frame.objects.assign(14, {"x", {}, {}});
  EXPECT_THROW((void)EncodeViconDatagram(frame), std::invalid_argument);
}

// Vicon EulerXYZ read as R = Rx(rx) Ry(ry) Rz(rz), checked on rotations computed by hand.
TEST(ViconEuler, SingleAxisRotationsAreHalfAngleQuaternions) {
  const double c = std::sqrt(0.5);
  const Eigen::Quaterniond qx = QuaternionFromViconEuler({kPi / 2, 0, 0});
  EXPECT_NEAR(qx.w(), c, 1e-15);
  EXPECT_NEAR(qx.x(), c, 1e-15);
  EXPECT_NEAR(qx.y(), 0.0, 1e-15);
  EXPECT_NEAR(qx.z(), 0.0, 1e-15);
  // Rx(90 deg) maps y to z.
  EXPECT_TRUE((qx * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  const Eigen::Quaterniond qz = QuaternionFromViconEuler({0, 0, kPi});
  EXPECT_NEAR(std::abs(qz.z()), 1.0, 1e-15);
}

TEST(ViconEuler, IntrinsicXyzComposesXThenZ) {
  // (rx, ry, rz) = (90, 0, 90) deg. q_x(90) * q_z(90) = (c, c, 0, 0) * (c, 0, 0, c) with c^2 = 1/2:
  // w = c*c = 1/2; v = c*(0,0,c) + c*(c,0,0) + (c,0,0) x (0,0,c) = (1/2, 0, 1/2) + (0, -1/2, 0).
  const Eigen::Quaterniond q = QuaternionFromViconEuler({kPi / 2, 0, kPi / 2});
  EXPECT_NEAR(q.w(), 0.5, 1e-15);
  EXPECT_NEAR(q.x(), 0.5, 1e-15);
  EXPECT_NEAR(q.y(), -0.5, 1e-15);
  EXPECT_NEAR(q.z(), 0.5, 1e-15);
  // Rz(90) takes body x to y, then Rx(90) takes y to z: body x ends along world z.
  EXPECT_TRUE((q * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  // The other order, Rz(90) Rx(90), leaves x on x then turns it to y.
  const Eigen::Quaterniond e =
      QuaternionFromViconEuler({kPi / 2, 0, kPi / 2}, ViconEulerOrder::kExtrinsicXyz);
  EXPECT_TRUE((e * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
}

TEST(ViconEuler, MatrixEntriesMatchTheClosedForm) {
  // R = Rx Ry Rz has R02 = sin(ry), R12 = -sin(rx) cos(ry), R22 = cos(rx) cos(ry),
  // R01 = -cos(ry) sin(rz), R00 = cos(ry) cos(rz), R10 = cos(rx) sin(rz) + sin(rx) sin(ry) cos(rz).
  const double rx = 0.3, ry = -0.7, rz = 1.9;
  const Eigen::Matrix3d R = QuaternionFromViconEuler({rx, ry, rz}).toRotationMatrix();
  EXPECT_NEAR(R(0, 2), std::sin(ry), 1e-14);
  EXPECT_NEAR(R(1, 2), -std::sin(rx) * std::cos(ry), 1e-14);
  EXPECT_NEAR(R(2, 2), std::cos(rx) * std::cos(ry), 1e-14);
  EXPECT_NEAR(R(0, 1), -std::cos(ry) * std::sin(rz), 1e-14);
  EXPECT_NEAR(R(0, 0), std::cos(ry) * std::cos(rz), 1e-14);
  EXPECT_NEAR(R(1, 0), std::cos(rx) * std::sin(rz) + std::sin(rx) * std::sin(ry) * std::cos(rz),
              1e-14);
}

TEST(ViconEuler, InverseRecoversAnglesAndHandlesGimbalLock) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> a(-kPi + 1e-6, kPi - 1e-6);
  std::uniform_real_distribution<double> b(-kPi / 2 + 1e-6, kPi / 2 - 1e-6);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d e(a(rng), b(rng), a(rng));
    const Eigen::Vector3d back = ViconEulerXyzFromQuaternion(QuaternionFromViconEuler(e));
    EXPECT_TRUE(back.isApprox(e, 1e-7)) << e.transpose() << " -> " << back.transpose();
  }
  for (const double ry : {kPi / 2, -kPi / 2}) {
    const Eigen::Quaterniond q = QuaternionFromViconEuler({0.4, ry, 0.3});
    const Eigen::Vector3d back = ViconEulerXyzFromQuaternion(q);
    EXPECT_EQ(back.z(), 0.0);
    EXPECT_LT(QuaternionFromViconEuler(back).angularDistance(q), 1e-9);
  }
}

}  // namespace
}  // namespace kestrel

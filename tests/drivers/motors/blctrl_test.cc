// The BL-Ctrl protocol's bytes and the thrust map (drivers/motors/blctrl.h, docs/protocols.md §6).
#include "drivers/motors/blctrl.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace kestrel {
namespace {

// docs/protocols.md §6.2: V1 one byte; V2 the upper eight of eleven bits, then the lower three.
TEST(BlCtrl, SetPointBytesAreTheProtocols) {
  EXPECT_EQ(EncodeBlCtrlSetPoint(BlCtrlVersion::kV1, 0), (std::vector<uint8_t>{0x00}));
  EXPECT_EQ(EncodeBlCtrlSetPoint(BlCtrlVersion::kV1, 200), (std::vector<uint8_t>{0xC8}));
  EXPECT_EQ(EncodeBlCtrlSetPoint(BlCtrlVersion::kV2, 2047), (std::vector<uint8_t>{0xFF, 0x07}));
  // 1234 = 0b100 1101 0010: upper eight 0b1001 1010 = 0x9A, lower three 0b010.
  EXPECT_EQ(EncodeBlCtrlSetPoint(BlCtrlVersion::kV2, 1234), (std::vector<uint8_t>{0x9A, 0x02}));
  EXPECT_THROW(static_cast<void>(EncodeBlCtrlSetPoint(BlCtrlVersion::kV1, 256)),
               std::invalid_argument);
  EXPECT_THROW(static_cast<void>(EncodeBlCtrlSetPoint(BlCtrlVersion::kV2, -1)),
               std::invalid_argument);
  for (int s = 0; s <= 2047; ++s) {
    ASSERT_EQ(DecodeBlCtrlSetPoint(BlCtrlVersion::kV2, EncodeBlCtrlSetPoint(BlCtrlVersion::kV2, s)),
              s);
  }
  EXPECT_FALSE(DecodeBlCtrlSetPoint(BlCtrlVersion::kV2, {0x10, 0x08}).has_value())
      << "lower bits beyond three";
  EXPECT_FALSE(DecodeBlCtrlSetPoint(BlCtrlVersion::kV1, {0x10, 0x00}).has_value());
  EXPECT_EQ(kBlCtrlFirstAddress << 1, 0x52) << "rotor 1 at the 8-bit write address 0x52";
}

TEST(BlCtrl, StatusBytesRoundTrip) {
  const auto status = DecodeBlCtrlStatus({37, 255, 41});
  ASSERT_TRUE(status.has_value());
  EXPECT_DOUBLE_EQ(status->current_A, 3.7);
  EXPECT_EQ(status->max_pwm, 255);
  EXPECT_EQ(status->temperature_C, 41);
  EXPECT_EQ(EncodeBlCtrlStatus(*status), (std::vector<uint8_t>{37, 255, 41}));
  EXPECT_FALSE(DecodeBlCtrlStatus({1, 2}).has_value());
}

// T(u) = T_full u^2: the set point is the rounded inverse, monotonic, clamped, idle when armed,
// zero when not armed or for a thrust that is not a number.
TEST(BlCtrl, ThrustMapInvertsWithinOneCountAndIsMonotonic) {
  EscMap map;
  map.full_command_thrust_N = 25.0;
  map.idle_command = 0.05;
  for (const BlCtrlVersion v : {BlCtrlVersion::kV1, BlCtrlVersion::kV2}) {
    const int full = BlCtrlFullScale(v);
    int last = 0;
    for (double t = 0.0; t <= 30.0; t += 0.01) {
      const int s = ThrustToBlCtrlSetPoint(map, v, t, true);
      ASSERT_GE(s, last) << "monotonic at " << t << " N";
      last = s;
      ASSERT_GE(s, static_cast<int>(std::ceil(0.05 * full))) << "idle while armed";
      ASSERT_LE(s, full);
      if (t <= 25.0 && s > static_cast<int>(std::ceil(0.05 * full))) {
        // The thrust of the set point is the asked thrust to within one count of the map.
        const double lo = BlCtrlSetPointToThrust(map, v, s - 1);
        const double hi = BlCtrlSetPointToThrust(map, v, s + 1 > full ? full : s + 1);
        ASSERT_GE(t, lo) << t;
        ASSERT_LE(t, hi) << t;
      }
    }
    EXPECT_EQ(ThrustToBlCtrlSetPoint(map, v, 30.0, true), full) << "clamped at full scale";
    EXPECT_EQ(ThrustToBlCtrlSetPoint(map, v, 10.0, false), 0) << "not armed: stopped";
    EXPECT_EQ(ThrustToBlCtrlSetPoint(map, v, std::numeric_limits<double>::quiet_NaN(), true), 0);
    EXPECT_EQ(ThrustToBlCtrlSetPoint(map, v, -std::numeric_limits<double>::infinity(), true), 0);
    EXPECT_DOUBLE_EQ(BlCtrlSetPointToThrust(map, v, full), 25.0);
  }
  // Hover of the paper's vehicle: 4.34 kg g / 4 = 10.64 N per rotor, u = 0.652, V2 set point 1336.
  EXPECT_EQ(ThrustToBlCtrlSetPoint(map, BlCtrlVersion::kV2, 4.34 * 9.80665 / 4.0, true),
            static_cast<int>(std::lround(2047 * std::sqrt(4.34 * 9.80665 / 4.0 / 25.0))));
}

}  // namespace
}  // namespace kestrel

// TRAJECTORY messages round-trip the trajectory exactly; inconsistent messages are refused.
#include "common/trajectory_message.h"

#include <gtest/gtest.h>

namespace kestrel {
namespace {

PiecewisePolynomialTrajectory MakeTrajectory() {
  std::vector<PolynomialSegment> segments(2);
  segments[0].duration_s = 1.5;
  segments[0].coefficients = {{{1.0, 0.5, -0.25}, {2.0}, {0.8, 0.0, 0.1, 0.01}, {0.3, 0.2}}};
  segments[1].duration_s = 0.75;
  segments[1].coefficients = {{{1.0}, {2.0, 1.0}, {0.9}, {0.6}}};
  return *PiecewisePolynomialTrajectory::Create(1234.5, segments, nullptr);
}

TEST(TrajectoryMessage, RoundTripsExactly) {
  const PiecewisePolynomialTrajectory t = MakeTrajectory();
  const trajectory_t msg = ToMessage(t, 42, 7, 0x1234567890);
  EXPECT_EQ(msg.seq, 7);
  EXPECT_EQ(msg.epoch, 0x1234567890);
  EXPECT_EQ(msg.start_utime, 1234500000);
  EXPECT_EQ(msg.num_segments, 2);
  EXPECT_EQ(msg.num_coeffs, 4);
  std::string error;
  const auto back = FromMessage(msg, &error);
  ASSERT_TRUE(back.has_value()) << error;
  for (double s = 1234.0; s < 1237.0; s += 0.01) {
    const FlatOutput a = t.Evaluate(s), b = back->Evaluate(s);
    EXPECT_EQ(a.position_m, b.position_m) << s;
    EXPECT_EQ(a.snap_mps4, b.snap_mps4) << s;
    EXPECT_EQ(a.yaw_rad, b.yaw_rad) << s;
  }
}

TEST(TrajectoryMessage, InconsistentMessagesAreRefused) {
  trajectory_t msg = ToMessage(MakeTrajectory(), 0, 0, 1);
  std::string error;
  trajectory_t short_row = msg;
  short_row.coeffs_y[1].pop_back();
  EXPECT_FALSE(FromMessage(short_row, &error).has_value());
  EXPECT_FALSE(error.empty());
  trajectory_t bad_count = msg;
  bad_count.num_segments = 3;
  EXPECT_FALSE(FromMessage(bad_count, &error).has_value());
  trajectory_t negative = msg;
  negative.durations_s[0] = -1.0;
  EXPECT_FALSE(FromMessage(negative, &error).has_value());
  trajectory_t nan = msg;
  nan.coeffs_z[0][2] = std::nan("");
  EXPECT_FALSE(FromMessage(nan, &error).has_value());
}

}  // namespace
}  // namespace kestrel

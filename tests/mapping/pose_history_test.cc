#include "mapping/pose_history.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

namespace kestrel {
namespace {

// A synthetic trajectory on which linear + slerp interpolation is exact: constant velocity and a
// constant rate about a fixed axis.
Pose3 TrajectoryAt(double t_s) {
  Pose3 X;
  X.p = Eigen::Vector3d(0.3, -1.0, 0.5) + t_s * Eigen::Vector3d(0.4, 0.25, -0.05);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
  X.q = Eigen::Quaterniond(Eigen::AngleAxisd(0.2 + 0.9 * t_s, axis));
  return X;
}

int64_t Us(double t_s) { return static_cast<int64_t>(std::llround(t_s * 1e6)); }

// Interpolated poses equal the analytic trajectory at random stamps between jittered 100 Hz
// poses (positions to 1e-12 m, orientations to 1e-9 rad), and a stamp equal to a pose's gives it.
TEST(PoseHistory, InterpolationIsExactOnSyntheticTrajectory) {
  PoseHistoryConfig config;
  config.history_s = 10.0;
  PoseHistory history(config);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> jitter(-0.002, 0.002);
  std::vector<int64_t> stamps;
  for (int i = 0; i < 500; ++i) {
    const int64_t t = Us(0.01 * i + jitter(rng));
    stamps.push_back(t);
    ASSERT_TRUE(history.Add(t, TrajectoryAt(1e-6 * t)));
  }
  std::uniform_real_distribution<double> when(0.01, 4.98);
  for (int n = 0; n < 2000; ++n) {
    const int64_t t = Us(when(rng));
    Pose3 X;
    ASSERT_EQ(history.Lookup(t, t, &X), PoseLookupResult::kOk);
    const Pose3 expected = TrajectoryAt(1e-6 * t);
    EXPECT_LT((X.p - expected.p).norm(), 1e-12);
    EXPECT_LT(AngleBetween(X.q, expected.q), 1e-9);
  }
  Pose3 X;
  ASSERT_EQ(history.Lookup(stamps[10], stamps[10], &X), PoseLookupResult::kOk);
  EXPECT_EQ(X.p, TrajectoryAt(1e-6 * stamps[10]).p);
}

// A stream of scans against a pose stream with a dropout: every skip case is counted, and the
// counts equal what the construction implies.
TEST(PoseHistory, CountsEachSkipCase) {
  PoseHistoryConfig config;
  config.history_s = 1.0;
  config.max_gap_s = 0.05;
  config.max_wait_s = 0.2;
  PoseHistory history(config);
  // Poses at 100 Hz over [0, 3] s, except a dropout (0.1 s gap) between 1.5 and 1.6 s.
  for (int i = 0; i <= 300; ++i) {
    if (i > 150 && i < 160) continue;
    history.Add(Us(0.01 * i), TrajectoryAt(0.01 * i));
  }
  EXPECT_FALSE(history.Add(Us(2.5), TrajectoryAt(2.5)));  // out of order: rejected, counted
  EXPECT_EQ(history.rejected_out_of_order(), 1u);
  std::map<PoseLookupResult, int> counts;
  const int64_t now = Us(3.0);
  Pose3 X;
  // Too old: the history keeps 1 s (from 2.0 s on).
  for (double t : {0.5, 1.2, 1.9}) counts[history.Lookup(Us(t), now, &X)]++;
  EXPECT_EQ(counts[PoseLookupResult::kTooOld], 3);
  // Newer than the latest pose: wait while within 0.2 s of now, then a gap.
  EXPECT_EQ(history.Lookup(Us(3.05), Us(3.1), &X), PoseLookupResult::kWait);
  EXPECT_EQ(history.Lookup(Us(3.05), Us(3.3), &X), PoseLookupResult::kGap);
  // In range: ok.
  EXPECT_EQ(history.Lookup(Us(2.555), now, &X), PoseLookupResult::kOk);
  EXPECT_LT((X.p - TrajectoryAt(2.555).p).norm(), 1e-12);

  // A second history that still holds the dropout: scans inside it are gaps, beside it ok.
  PoseHistoryConfig long_config = config;
  long_config.history_s = 5.0;
  PoseHistory full(long_config);
  for (int i = 0; i <= 300; ++i) {
    if (i > 150 && i < 160) continue;
    full.Add(Us(0.01 * i), TrajectoryAt(0.01 * i));
  }
  int gaps = 0, ok = 0;
  for (int k = 0; k < 300; ++k) {  // scans every 10 ms, offset by 5 ms
    const double t = 0.005 + 0.01 * k;
    const PoseLookupResult r = full.Lookup(Us(t), Us(3.0), &X);
    gaps += r == PoseLookupResult::kGap;
    ok += r == PoseLookupResult::kOk;
  }
  EXPECT_EQ(gaps, 10);  // 1.505 .. 1.595
  EXPECT_EQ(ok, 290);
  EXPECT_STREQ(ToString(PoseLookupResult::kTooOld), "too_old");
}

TEST(PoseHistory, ValidateRejectsBadConfig) {
  PoseHistoryConfig config;
  config.max_gap_s = 5.0;  // > history_s
  EXPECT_THROW(config.Validate(), std::invalid_argument);
  config = PoseHistoryConfig{};
  config.max_wait_s = 0.0;
  EXPECT_THROW(PoseHistory{config}, std::invalid_argument);
}

}  // namespace
}  // namespace kestrel

#include "common/trajectory.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace kestrel {
namespace {

// Shifts polynomial c (in tau) to the variable s = tau - t0: returns d with
// sum d[k] s^k == sum c[k] (s + t0)^k, by the binomial theorem (an independent construction).
std::vector<double> ShiftPolynomial(const std::vector<double>& c, double t0) {
  std::vector<double> d(c.size(), 0.0);
  for (size_t k = 0; k < c.size(); ++k) {
    double binomial = 1.0;  // C(k, j)
    for (size_t j = 0; j <= k; ++j) {
      d[j] += c[k] * binomial * std::pow(t0, static_cast<double>(k - j));
      binomial = binomial * static_cast<double>(k - j) / static_cast<double>(j + 1);
    }
  }
  return d;
}

PolynomialSegment RandomSegment(std::mt19937* rng, double duration_s, int num_coefficients) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PolynomialSegment segment;
  segment.duration_s = duration_s;
  for (auto& c : segment.coefficients) {
    c.resize(static_cast<size_t>(num_coefficients));
    for (double& value : c) value = u(*rng);
  }
  return segment;
}

// A single segment whose derivatives are known in closed form.
TEST(PiecewisePolynomialTrajectory, MatchesClosedFormDerivatives) {
  // x = 1 + 2t + 3t^2 - t^3 + 0.5 t^5, y = -2 t^4, z = 0.7, yaw = 0.1 + 0.3 t - 0.2 t^2.
  PolynomialSegment segment;
  segment.duration_s = 2.0;
  segment.coefficients = {std::vector<double>{1, 2, 3, -1, 0, 0.5},
                          std::vector<double>{0, 0, 0, 0, -2}, std::vector<double>{0.7},
                          std::vector<double>{0.1, 0.3, -0.2}};
  const auto trajectory = PiecewisePolynomialTrajectory::Create(10.0, {segment}, nullptr);
  ASSERT_TRUE(trajectory.has_value());
  for (const double t : {0.0, 0.3, 1.0, 1.7, 2.0}) {
    const FlatOutput f = trajectory->Evaluate(10.0 + t);
    EXPECT_NEAR(f.position_m.x(), 1 + 2 * t + 3 * t * t - t * t * t + 0.5 * std::pow(t, 5), 1e-12);
    EXPECT_NEAR(f.velocity_mps.x(), 2 + 6 * t - 3 * t * t + 2.5 * std::pow(t, 4), 1e-12);
    EXPECT_NEAR(f.acceleration_mps2.x(), 6 - 6 * t + 10 * std::pow(t, 3), 1e-12);
    EXPECT_NEAR(f.jerk_mps3.x(), -6 + 30 * t * t, 1e-12);
    EXPECT_NEAR(f.snap_mps4.x(), 60 * t, 1e-12);
    EXPECT_NEAR(f.position_m.y(), -2 * std::pow(t, 4), 1e-12);
    EXPECT_NEAR(f.velocity_mps.y(), -8 * std::pow(t, 3), 1e-12);
    EXPECT_NEAR(f.acceleration_mps2.y(), -24 * t * t, 1e-12);
    EXPECT_NEAR(f.jerk_mps3.y(), -48 * t, 1e-12);
    EXPECT_NEAR(f.snap_mps4.y(), -48, 1e-12);
    EXPECT_EQ(f.position_m.z(), 0.7);
    EXPECT_EQ(f.velocity_mps.z(), 0.0);
    EXPECT_EQ(f.snap_mps4.z(), 0.0);
    EXPECT_NEAR(f.yaw_rad, 0.1 + 0.3 * t - 0.2 * t * t, 1e-12);
    EXPECT_NEAR(f.yaw_rate_radps, 0.3 - 0.4 * t, 1e-12);
    EXPECT_NEAR(f.yaw_acceleration_radps2, -0.4, 1e-12);
  }
}

// Each derivative is the central finite difference of the one below it (degree 9, 3 segments).
TEST(PiecewisePolynomialTrajectory, DerivativesMatchFiniteDifferences) {
  std::mt19937 rng(7);
  std::vector<PolynomialSegment> segments = {
      RandomSegment(&rng, 0.8, 10), RandomSegment(&rng, 1.3, 10), RandomSegment(&rng, 0.5, 10)};
  const auto trajectory = PiecewisePolynomialTrajectory::Create(-1.0, segments, nullptr);
  ASSERT_TRUE(trajectory.has_value());
  const double h = 1e-5;
  // Points strictly inside segments (finite differences must not straddle a knot).
  for (const double t : {-0.9, -0.5, -0.3, 0.2, 0.9, 1.25}) {
    const FlatOutput m = trajectory->Evaluate(t - h);
    const FlatOutput p = trajectory->Evaluate(t + h);
    const FlatOutput c = trajectory->Evaluate(t);
    const double tol = 1e-6;
    EXPECT_LT(((p.position_m - m.position_m) / (2 * h) - c.velocity_mps).norm(), tol) << t;
    EXPECT_LT(((p.velocity_mps - m.velocity_mps) / (2 * h) - c.acceleration_mps2).norm(), tol) << t;
    EXPECT_LT(((p.acceleration_mps2 - m.acceleration_mps2) / (2 * h) - c.jerk_mps3).norm(), 1e-5)
        << t;
    EXPECT_LT(((p.jerk_mps3 - m.jerk_mps3) / (2 * h) - c.snap_mps4).norm(), 1e-4) << t;
    EXPECT_NEAR((p.yaw_rad - m.yaw_rad) / (2 * h), c.yaw_rate_radps, tol) << t;
    EXPECT_NEAR((p.yaw_rate_radps - m.yaw_rate_radps) / (2 * h), c.yaw_acceleration_radps2, tol)
        << t;
  }
}

// A polynomial split at a knot and re-expanded is continuous in every derivative across it, and
// equals the unsplit polynomial everywhere.
TEST(PiecewisePolynomialTrajectory, SplitPolynomialIsContinuousAtKnots) {
  std::mt19937 rng(11);
  const PolynomialSegment whole = RandomSegment(&rng, 2.0, 8);
  PolynomialSegment first = whole;
  first.duration_s = 0.7;
  PolynomialSegment second;
  second.duration_s = 1.3;
  // The second piece in its local time s = tau - 0.7.
  for (size_t axis = 0; axis < 4; ++axis) {
    second.coefficients[axis] = ShiftPolynomial(whole.coefficients[axis], 0.7);
  }
  const auto split = PiecewisePolynomialTrajectory::Create(0.0, {first, second}, nullptr);
  const auto reference = PiecewisePolynomialTrajectory::Create(0.0, {whole}, nullptr);
  ASSERT_TRUE(split.has_value());
  ASSERT_TRUE(reference.has_value());
  EXPECT_EQ(split->num_segments(), 2);
  EXPECT_DOUBLE_EQ(split->duration_s(), 2.0);
  for (const double t : {0.0, 0.5, 0.7 - 1e-12, 0.7, 0.7 + 1e-12, 1.1, 2.0}) {
    const FlatOutput a = split->Evaluate(t);
    const FlatOutput b = reference->Evaluate(t);
    EXPECT_LT((a.position_m - b.position_m).norm(), 1e-11) << t;
    EXPECT_LT((a.velocity_mps - b.velocity_mps).norm(), 1e-10) << t;
    EXPECT_LT((a.acceleration_mps2 - b.acceleration_mps2).norm(), 1e-10) << t;
    EXPECT_LT((a.jerk_mps3 - b.jerk_mps3).norm(), 1e-9) << t;
    EXPECT_LT((a.snap_mps4 - b.snap_mps4).norm(), 1e-8) << t;
    EXPECT_NEAR(a.yaw_rad, b.yaw_rad, 1e-11) << t;
    EXPECT_NEAR(a.yaw_rate_radps, b.yaw_rate_radps, 1e-10) << t;
    EXPECT_NEAR(a.yaw_acceleration_radps2, b.yaw_acceleration_radps2, 1e-10) << t;
  }
}

// A knot where the pieces do not meet shows the jump (the evaluator does not smooth it away):
// the later segment is used at the knot.
TEST(PiecewisePolynomialTrajectory, UsesLaterSegmentAtKnot) {
  PolynomialSegment a;
  a.duration_s = 1.0;
  a.coefficients = {std::vector<double>{0.0, 1.0}, std::vector<double>{0.0},
                    std::vector<double>{1.0}, std::vector<double>{0.0}};
  PolynomialSegment b = a;
  b.coefficients[0] = {5.0};
  const auto trajectory = PiecewisePolynomialTrajectory::Create(0.0, {a, b}, nullptr);
  ASSERT_TRUE(trajectory.has_value());
  EXPECT_NEAR(trajectory->Evaluate(1.0 - 1e-9).position_m.x(), 1.0, 1e-8);
  EXPECT_EQ(trajectory->Evaluate(1.0).position_m.x(), 5.0);
  EXPECT_EQ(trajectory->Evaluate(1.0).velocity_mps.x(), 0.0);
}

// Before the start and after the end: the end points with all derivatives zero.
TEST(PiecewisePolynomialTrajectory, ClampsOutsideWithZeroDerivatives) {
  std::mt19937 rng(3);
  const auto trajectory =
      PiecewisePolynomialTrajectory::Create(5.0, {RandomSegment(&rng, 1.5, 6)}, nullptr);
  ASSERT_TRUE(trajectory.has_value());
  const FlatOutput start = trajectory->Evaluate(5.0);
  const FlatOutput end = trajectory->Evaluate(6.5);
  for (const double t : {-100.0, 4.999, std::numeric_limits<double>::quiet_NaN()}) {
    const FlatOutput f = trajectory->Evaluate(t);
    EXPECT_EQ(f.position_m, start.position_m);
    EXPECT_EQ(f.yaw_rad, start.yaw_rad);
    EXPECT_TRUE(f.velocity_mps.isZero() && f.acceleration_mps2.isZero() && f.jerk_mps3.isZero() &&
                f.snap_mps4.isZero());
    EXPECT_EQ(f.yaw_rate_radps, 0.0);
    EXPECT_EQ(f.yaw_acceleration_radps2, 0.0);
  }
  EXPECT_FALSE(end.velocity_mps.isZero());  // true derivatives exactly at the end
  for (const double t : {6.5001, 1e6}) {
    const FlatOutput f = trajectory->Evaluate(t);
    EXPECT_EQ(f.position_m, end.position_m);
    EXPECT_EQ(f.yaw_rad, end.yaw_rad);
    EXPECT_TRUE(f.velocity_mps.isZero() && f.acceleration_mps2.isZero() && f.jerk_mps3.isZero() &&
                f.snap_mps4.isZero());
    EXPECT_EQ(f.yaw_rate_radps, 0.0);
  }
}

// The display sampler: every dt from the start, the last sample at the end.
TEST(PiecewisePolynomialTrajectory, SamplesEveryHundredthOfASecond) {
  std::mt19937 rng(5);
  const auto trajectory = PiecewisePolynomialTrajectory::Create(
      2.0, {RandomSegment(&rng, 0.5, 4), RandomSegment(&rng, 0.555, 4)}, nullptr);
  ASSERT_TRUE(trajectory.has_value());
  const std::vector<TrajectorySample> samples = trajectory->Sample();
  ASSERT_EQ(samples.size(), 107u);  // 0, 0.01, ..., 1.05, then 1.055
  for (size_t k = 0; k + 1 < samples.size(); ++k) {
    EXPECT_NEAR(samples[k].time_s, 2.0 + 0.01 * static_cast<double>(k), 1e-12);
    EXPECT_EQ(samples[k].flat.position_m, trajectory->Evaluate(samples[k].time_s).position_m);
  }
  EXPECT_DOUBLE_EQ(samples.back().time_s, trajectory->end_time_s());
  EXPECT_THROW((void)trajectory->Sample(0.0), std::invalid_argument);
}

// Bad input is rejected with a reason naming the problem, never a crash.
TEST(PiecewisePolynomialTrajectory, RejectsBadInputWithAReason) {
  std::mt19937 rng(1);
  std::string error;
  EXPECT_FALSE(PiecewisePolynomialTrajectory::Create(0.0, {}, &error).has_value());
  EXPECT_NE(error.find("no segments"), std::string::npos) << error;

  for (const double duration : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                                std::numeric_limits<double>::infinity()}) {
    EXPECT_FALSE(PiecewisePolynomialTrajectory::Create(
                     0.0, {RandomSegment(&rng, 1.0, 3), RandomSegment(&rng, duration, 3)}, &error)
                     .has_value());
    EXPECT_NE(error.find("segment 1: duration_s"), std::string::npos) << error;
  }

  PolynomialSegment nan_coefficient = RandomSegment(&rng, 1.0, 3);
  nan_coefficient.coefficients[2][1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(PiecewisePolynomialTrajectory::Create(0.0, {nan_coefficient}, &error).has_value());
  EXPECT_NE(error.find("axis z: coefficient 1"), std::string::npos) << error;

  PolynomialSegment empty_axis = RandomSegment(&rng, 1.0, 3);
  empty_axis.coefficients[3].clear();
  EXPECT_FALSE(PiecewisePolynomialTrajectory::Create(0.0, {empty_axis}, &error).has_value());
  EXPECT_NE(error.find("axis yaw: 0 coefficients"), std::string::npos) << error;

  const PolynomialSegment too_long =
      RandomSegment(&rng, 1.0, PiecewisePolynomialTrajectory::kMaxCoefficients + 1);
  EXPECT_FALSE(PiecewisePolynomialTrajectory::Create(0.0, {too_long}, &error).has_value());

  EXPECT_FALSE(PiecewisePolynomialTrajectory::Create(std::numeric_limits<double>::quiet_NaN(),
                                                     {RandomSegment(&rng, 1.0, 3)}, &error)
                   .has_value());

  // Flat layout: sizes must agree with durations x num_coefficients.
  const std::vector<double> ok(6, 0.5);
  const std::vector<double> short_one(5, 0.5);
  EXPECT_TRUE(
      PiecewisePolynomialTrajectory::CreateFromFlat(0.0, {1.0, 2.0}, 3, ok, ok, ok, ok, &error)
          .has_value())
      << error;
  EXPECT_FALSE(PiecewisePolynomialTrajectory::CreateFromFlat(0.0, {1.0, 2.0}, 3, ok, ok, short_one,
                                                             ok, &error)
                   .has_value());
  EXPECT_NE(error.find("axis z has 5 coefficients, expected 2 segments x 3 = 6"), std::string::npos)
      << error;
  EXPECT_FALSE(
      PiecewisePolynomialTrajectory::CreateFromFlat(0.0, {1.0, 2.0}, 0, ok, ok, ok, ok, &error)
          .has_value());
  EXPECT_FALSE(PiecewisePolynomialTrajectory::CreateFromFlat(0.0, {}, 3, {}, {}, {}, {}, &error)
                   .has_value());
}

// The flat layout puts segment i's coefficients at [i n, (i + 1) n).
TEST(PiecewisePolynomialTrajectory, FlatLayoutIsSegmentMajor) {
  const std::vector<double> x = {1.0, 2.0, 10.0, 20.0};  // seg 0: 1 + 2t, seg 1: 10 + 20t
  const std::vector<double> zero(4, 0.0);
  const auto trajectory = PiecewisePolynomialTrajectory::CreateFromFlat(0.0, {1.0, 1.0}, 2, x, zero,
                                                                        zero, zero, nullptr);
  ASSERT_TRUE(trajectory.has_value());
  EXPECT_DOUBLE_EQ(trajectory->Evaluate(0.5).position_m.x(), 2.0);
  EXPECT_DOUBLE_EQ(trajectory->Evaluate(1.5).position_m.x(), 20.0);
  EXPECT_DOUBLE_EQ(trajectory->Evaluate(1.5).velocity_mps.x(), 20.0);
}

// ToFlat pads to a common coefficient count; CreateFromFlat of it is the same trajectory.
TEST(PiecewisePolynomialTrajectory, FlatLayoutRoundTrips) {
  std::mt19937 rng(9);
  PolynomialSegment a = RandomSegment(&rng, 0.7, 6);
  a.coefficients[3] = {0.5};  // a shorter yaw polynomial
  const PolynomialSegment b = RandomSegment(&rng, 1.1, 8);
  const auto trajectory = PiecewisePolynomialTrajectory::Create(3.0, {a, b}, nullptr);
  ASSERT_TRUE(trajectory.has_value());
  const FlatTrajectory flat = trajectory->ToFlat();
  EXPECT_EQ(flat.num_coefficients, 8);
  EXPECT_EQ(flat.x.size(), 16u);
  EXPECT_EQ(flat.yaw[1], 0.0);  // padding
  std::string error;
  const auto copy = PiecewisePolynomialTrajectory::CreateFromFlat(
      flat.start_time_s, flat.durations_s, flat.num_coefficients, flat.x, flat.y, flat.z, flat.yaw,
      &error);
  ASSERT_TRUE(copy.has_value()) << error;
  for (double t = 2.9; t < 5.0; t += 0.05) {
    const FlatOutput p = trajectory->Evaluate(t);
    const FlatOutput q = copy->Evaluate(t);
    EXPECT_EQ(p.position_m, q.position_m);
    EXPECT_EQ(p.snap_mps4, q.snap_mps4);
    EXPECT_EQ(p.yaw_rad, q.yaw_rad);
  }
}

// TaylorShift (Horner's scheme) agrees with the binomial expansion, for any shift.
TEST(TaylorShift, MatchesTheBinomialExpansion) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<double> c(static_cast<size_t>(1 + trial % 10));
    for (double& value : c) value = u(rng);
    const double shift = 2.0 * u(rng);
    const std::vector<double> a = TaylorShift(c, shift), b = ShiftPolynomial(c, shift);
    ASSERT_EQ(a.size(), c.size());
    for (size_t k = 0; k < c.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-12 * (1.0 + std::abs(b[k])));
  }
  EXPECT_EQ(TaylorShift({1.0, 2.0, 3.0}, 0.0), (std::vector<double>{1.0, 2.0, 3.0}));
}

// A trajectory from start_s of `pieces` pieces (durations 0.6 to 1.4 s) of ONE random degree-7
// polynomial, so that it is smooth across its knots (where a discontinuous one would be
// evaluated on either side depending on rounding).
PiecewisePolynomialTrajectory RandomTrajectory(std::mt19937* rng, double start_s, int pieces) {
  std::uniform_real_distribution<double> u(0.6, 1.4);
  const PolynomialSegment whole = RandomSegment(rng, 1.0, 8);
  std::vector<PolynomialSegment> segments;
  double offset_s = 0.0;
  for (int i = 0; i < pieces; ++i) {
    PolynomialSegment piece;
    piece.duration_s = u(*rng);
    for (size_t axis = 0; axis < 4; ++axis) {
      piece.coefficients[axis] = ShiftPolynomial(whole.coefficients[axis], offset_s);
    }
    offset_s += piece.duration_s;
    segments.push_back(piece);
  }
  return *PiecewisePolynomialTrajectory::Create(start_s, segments, nullptr);
}

// Every member of two flat outputs agrees within tol (relative to 1 + the magnitude).
void ExpectSameFlat(const FlatOutput& a, const FlatOutput& b, double tol, double t) {
  const auto near = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& y, const char* what) {
    EXPECT_LT((x - y).norm(), tol * (1.0 + y.norm())) << what << " at t " << t;
  };
  near(a.position_m, b.position_m, "position");
  near(a.velocity_mps, b.velocity_mps, "velocity");
  near(a.acceleration_mps2, b.acceleration_mps2, "acceleration");
  near(a.jerk_mps3, b.jerk_mps3, "jerk");
  near(a.snap_mps4, b.snap_mps4, "snap");
  EXPECT_NEAR(a.yaw_rad, b.yaw_rad, tol * (1.0 + std::abs(b.yaw_rad))) << t;
  EXPECT_NEAR(a.yaw_rate_radps, b.yaw_rate_radps, tol * (1.0 + std::abs(b.yaw_rate_radps))) << t;
  EXPECT_NEAR(a.yaw_acceleration_radps2, b.yaw_acceleration_radps2,
              tol * (1.0 + std::abs(b.yaw_acceleration_radps2)))
      << t;
}

// The spliced trajectory starts at now, equals the old one until the splice time and the next one
// from then on (1e-9), wherever now and the splice time fall: inside a piece, on a knot, before
// the old trajectory's start, after its end, or both at once.
TEST(Splice, EqualsOldBeforeTheSpliceAndNextAfter) {
  std::mt19937 rng(23);
  const PiecewisePolynomialTrajectory old = RandomTrajectory(&rng, 10.0, 3);
  const double k1 = 10.0 + old.segments()[0].duration_s;
  const double k2 = k1 + old.segments()[1].duration_s;
  const std::vector<std::pair<double, double>> cases = {{10.3, k1 + 0.2},
                                                        {10.2, 10.5},
                                                        {k1, k2},
                                                        {10.0, 10.0},
                                                        {10.4, 10.4},
                                                        {8.5, 10.7},
                                                        {8.5, 9.5},
                                                        {k2 + 0.1, 100.0},
                                                        {old.end_time_s() + 1.0, 200.0},
                                                        {9.0, old.end_time_s()}};
  for (const auto& [now_s, splice_s] : cases) {
    const PiecewisePolynomialTrajectory next = RandomTrajectory(&rng, splice_s, 2);
    const auto spliced = Splice(old, now_s, next);
    ASSERT_TRUE(spliced.has_value()) << now_s << " " << splice_s;
    SCOPED_TRACE(std::to_string(now_s) + " " + std::to_string(splice_s));
    EXPECT_EQ(spliced->start_time_s(), now_s);
    EXPECT_NEAR(spliced->end_time_s(), next.end_time_s(), 1e-9);
    for (double t = now_s; t < splice_s - 1e-9; t += std::max(0.01, (splice_s - now_s) / 200)) {
      ExpectSameFlat(spliced->Evaluate(t), old.Evaluate(t), 1e-9, t);
    }
    for (double t = splice_s; t <= next.end_time_s() + 0.5; t += 0.0137) {
      ExpectSameFlat(spliced->Evaluate(t), next.Evaluate(t), 1e-9, t);
    }
  }
}

// Planned from StateAt(old, t_splice), the next trajectory continues the old one: position,
// velocity and acceleration (and yaw, yaw rate) are continuous at the splice.
TEST(Splice, ContinuousWhenNextStartsFromStateAt) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const PiecewisePolynomialTrajectory old = RandomTrajectory(&rng, 3.0, 3);
    const double now_s = 3.0 + 0.1 * trial;
    const double splice_s = now_s + 0.3;
    const TrajectoryStart state = StateAt(old, splice_s);
    const FlatOutput at = old.Evaluate(splice_s);
    EXPECT_EQ(state.time_s, splice_s);
    EXPECT_EQ(state.position_m, at.position_m);
    EXPECT_EQ(state.velocity_mps, at.velocity_mps);
    EXPECT_EQ(state.acceleration_mps2, at.acceleration_mps2);
    EXPECT_EQ(state.yaw_rad, at.yaw_rad);
    EXPECT_EQ(state.yaw_rate_radps, at.yaw_rate_radps);
    // A next trajectory starting with that state (and anything in its higher coefficients).
    PolynomialSegment first = RandomSegment(&rng, 1.0, 8);
    for (size_t axis = 0; axis < 3; ++axis) {
      first.coefficients[axis][0] = state.position_m[static_cast<int>(axis)];
      first.coefficients[axis][1] = state.velocity_mps[static_cast<int>(axis)];
      first.coefficients[axis][2] = 0.5 * state.acceleration_mps2[static_cast<int>(axis)];
    }
    first.coefficients[3][0] = state.yaw_rad;
    first.coefficients[3][1] = state.yaw_rate_radps;
    const auto next = PiecewisePolynomialTrajectory::Create(splice_s, {first}, nullptr);
    ASSERT_TRUE(next.has_value());
    const auto spliced = Splice(old, now_s, *next);
    ASSERT_TRUE(spliced.has_value());
    const FlatOutput before = spliced->Evaluate(splice_s - 1e-9);
    const FlatOutput after = spliced->Evaluate(splice_s);
    EXPECT_LT((after.position_m - at.position_m).norm(), 1e-9);
    EXPECT_LT((after.velocity_mps - at.velocity_mps).norm(), 1e-9);
    EXPECT_LT((after.acceleration_mps2 - at.acceleration_mps2).norm(), 1e-9);
    EXPECT_NEAR(after.yaw_rad, at.yaw_rad, 1e-9);
    EXPECT_NEAR(after.yaw_rate_radps, at.yaw_rate_radps, 1e-9);
    // Just before the splice (1e-9 s): the change is that of the next derivative over 1e-9 s.
    EXPECT_LT((after.position_m - before.position_m).norm(),
              2e-9 * (1.0 + before.velocity_mps.norm()));
    EXPECT_LT((after.velocity_mps - before.velocity_mps).norm(),
              2e-9 * (1.0 + before.acceleration_mps2.norm()));
    EXPECT_LT((after.acceleration_mps2 - before.acceleration_mps2).norm(),
              2e-9 * (1.0 + before.jerk_mps3.norm()));
  }
}

// No splice into the past, nor at a time that is not finite.
TEST(Splice, RejectsANextTrajectoryStartingBeforeNow) {
  std::mt19937 rng(31);
  const PiecewisePolynomialTrajectory old = RandomTrajectory(&rng, 0.0, 2);
  const PiecewisePolynomialTrajectory next = RandomTrajectory(&rng, 1.0, 1);
  EXPECT_FALSE(Splice(old, 1.2, next).has_value());
  EXPECT_FALSE(Splice(old, std::numeric_limits<double>::quiet_NaN(), next).has_value());
  EXPECT_TRUE(Splice(old, 1.0, next).has_value());
}

// The go-to move: at rest at both ends (velocity, acceleration and jerk zero), the end point
// reached at the duration, the midpoint half way (the polynomial is symmetric), and the peak speed
// 35/16 of the mean speed (the degree-7 rest-to-rest profile's maximum, at s = 1/2).
TEST(RestToRest, StartsAndEndsAtRestAndPeaksAtTheKnownSpeed) {
  const Eigen::Vector3d from(1.0, -2.0, 0.8), to(2.5, -1.0, 1.2);
  std::string error;
  const auto move = RestToRest(10.0, from, to, 0.3, 4.0, &error);
  ASSERT_TRUE(move.has_value()) << error;
  for (const double t : {10.0, 14.0}) {
    const FlatOutput f = move->Evaluate(t);
    EXPECT_LT(f.velocity_mps.norm(), 1e-12) << t;
    EXPECT_LT(f.acceleration_mps2.norm(), 1e-12) << t;
    EXPECT_LT(f.jerk_mps3.norm(), 1e-12) << t;
    EXPECT_DOUBLE_EQ(f.yaw_rad, 0.3);
  }
  EXPECT_LT((move->Evaluate(10.0).position_m - from).norm(), 1e-12);
  EXPECT_LT((move->Evaluate(14.0).position_m - to).norm(), 1e-12);
  EXPECT_LT((move->Evaluate(12.0).position_m - 0.5 * (from + to)).norm(), 1e-12);
  const double mean_speed = (to - from).norm() / 4.0;
  EXPECT_NEAR(move->Evaluate(12.0).velocity_mps.norm(), 35.0 / 16.0 * mean_speed, 1e-12);
  double fastest = 0.0;
  for (double t = 10.0; t <= 14.0; t += 0.01) {
    fastest = std::max(fastest, move->Evaluate(t).velocity_mps.norm());
  }
  EXPECT_LE(fastest, 35.0 / 16.0 * mean_speed + 1e-12);
  EXPECT_FALSE(RestToRest(0.0, from, to, 0.0, 0.0, &error).has_value());
  EXPECT_FALSE(RestToRest(0.0, from, Eigen::Vector3d(NAN, 0, 0), 0.0, 1.0, &error).has_value());
  EXPECT_NE(error.find("rest-to-rest"), std::string::npos);
}

}  // namespace
}  // namespace kestrel

#include "exploration/startup_turn.h"

#include "exploration/trajectory_planner.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace kestrel {
namespace {

// The degree-7 polynomial (ascending powers of tau, s) with p(0) = p0, p'(0) = v0, p''(0) = a0,
// p'''(0) = 0 and p(T) = p1, p'(T) = p''(T) = p'''(T) = 0. With v0 = a0 = 0 it is the smoothstep
// p0 + (p1 - p0) (35 s^4 - 84 s^5 + 70 s^6 - 20 s^7), s = tau / T.
std::vector<double> ToRest(double p0, double v0, double a0, double p1, double T) {
  // In normalised time s = tau / T: b0..b3 from the start, b4..b7 from the end conditions.
  const double b0 = p0, b1 = v0 * T, b2 = 0.5 * a0 * T * T;
  Eigen::Matrix4d A;
  A << 1, 1, 1, 1,  //
      4, 5, 6, 7,   //
      12, 20, 30, 42, 24, 60, 120, 210;
  const Eigen::Vector4d rhs(p1 - (b0 + b1 + b2), -(b1 + 2 * b2), -2 * b2, 0.0);
  const Eigen::Vector4d b47 = A.fullPivLu().solve(rhs);
  std::vector<double> c{b0, b1, b2, 0.0, b47[0], b47[1], b47[2], b47[3]};
  for (size_t k = 1; k < c.size(); ++k) c[k] /= std::pow(T, static_cast<double>(k));
  return c;
}

// Whether the vertical polynomial c over [0, T] respects the limits and stays between lo and hi.
bool VerticalOk(const std::vector<double>& c, double T, const StartupTurnLimits& limits, double lo,
                double hi) {
  const int n = std::max(50, static_cast<int>(std::ceil(T / 0.01)));
  for (int i = 0; i <= n; ++i) {
    double d[5];
    EvaluatePolynomial(c, T * i / n, d);
    if (d[0] < lo || d[0] > hi || std::abs(d[1]) > limits.max_speed_mps + 1e-9 ||
        std::abs(d[2]) > limits.max_acceleration_mps2 + 1e-9) {
      return false;
    }
  }
  return true;
}

}  // namespace

std::optional<PiecewisePolynomialTrajectory> PlanStartupTurn(const TrajectoryStart& start,
                                                             double height_m,
                                                             const StartupTurnLimits& limits,
                                                             std::string* error) {
  auto fail = [&](const std::string& why) -> std::optional<PiecewisePolynomialTrajectory> {
    if (error != nullptr) *error = why;
    return std::nullopt;
  };
  if (!start.position_m.allFinite() || !start.velocity_mps.allFinite() ||
      !start.acceleration_mps2.allFinite() || !std::isfinite(start.yaw_rad) ||
      !std::isfinite(start.time_s) || !std::isfinite(height_m)) {
    return fail("start-up turn: non-finite start state or height");
  }
  if (!(limits.max_speed_mps > 0) || !(limits.max_acceleration_mps2 > 0) ||
      !(limits.peak_yaw_rate_radps > 0)) {
    return fail("start-up turn: the limits must be > 0");
  }
  const double z0 = start.position_m.z();
  const double v0 = start.velocity_mps.z();
  const double a0 = start.acceleration_mps2.z();

  // z: the shortest duration on a 1% grid that meets the limits (none needed at rest at h).
  double t_z = 0.0;
  std::vector<double> z_poly{height_m};
  if (std::abs(height_m - z0) > 1e-6 || std::abs(v0) > 1e-6 || std::abs(a0) > 1e-6) {
    // First within 2 cm of the span between z0 and h; if no duration does that (moving away
    // from h, or too fast to stop at h), allow 3 v0^2 / a_max (six times the stopping distance at
    // constant deceleration: one polynomial from zero jerk builds its deceleration up slowly;
    // from 0.2 m/s away from h at 1 m/s^2 it overshoots 8.8 cm) on the side v0 points to.
    const double stop_m = 3.0 * v0 * v0 / limits.max_acceleration_mps2;
    for (const double widen : {0.0, 1.0}) {
      const double lo = std::min(z0, height_m) - 0.02 - (v0 < 0 ? widen * stop_m : 0.0);
      const double hi = std::max(z0, height_m) + 0.02 + (v0 > 0 ? widen * stop_m : 0.0);
      for (double T = 0.05; T <= 60.0 && t_z == 0.0; T *= 1.01) {
        std::vector<double> c = ToRest(z0, v0, a0, height_m, T);
        if (VerticalOk(c, T, limits, lo, hi)) {
          t_z = T;
          z_poly = std::move(c);
        }
      }
      if (t_z > 0.0) break;
    }
    if (t_z == 0.0) {
      return fail("start-up turn: no climb from z " + std::to_string(z0) + " m at " +
                  std::to_string(v0) + " m/s to h " + std::to_string(height_m) +
                  " m meets the limits within 60 s");
    }
  }

  // yaw: the full circle, one smoothstep or the planner's ramped profile, at the peak rate.
  const double yaw0 = start.yaw_rad;
  std::vector<YawPiece> yaw;
  if (limits.yaw_profile == StartupYawProfile::kSmoothstep) {
    const double t_yaw = 35.0 / 16.0 * 2.0 * M_PI / limits.peak_yaw_rate_radps;
    yaw = {{t_yaw, ToRest(yaw0, 0.0, 0.0, yaw0 + 2.0 * M_PI, t_yaw)}, {0.0, {yaw0 + 2.0 * M_PI}}};
  } else {
    yaw = YawProfile(yaw0, 0.0, 2.0 * M_PI, limits.peak_yaw_rate_radps);
  }
  std::vector<YawPiece> z;
  if (t_z > 0.0) z.push_back({t_z, z_poly});
  z.push_back({0.0, {height_m}});

  // Pieces at the union of both profiles' knots (each profile's last piece holds its end).
  const auto knots_of = [](const std::vector<YawPiece>& pieces) {
    std::vector<double> knots{0.0};
    for (size_t j = 0; j + 1 < pieces.size(); ++j)
      knots.push_back(knots.back() + pieces[j].duration_s);
    return knots;
  };
  const std::vector<double> z_knots = knots_of(z), yaw_knots = knots_of(yaw);
  std::vector<double> knots = z_knots;
  knots.insert(knots.end(), yaw_knots.begin(), yaw_knots.end());
  std::sort(knots.begin(), knots.end());
  std::vector<double> unique{0.0};
  for (double k : knots) {
    if (k > unique.back() + 1e-6) unique.push_back(k);
  }
  // The piece of a profile holding local time t, expanded about t0.
  const auto coefficients = [](const std::vector<YawPiece>& pieces,
                               const std::vector<double>& piece_knots, double t, double t0) {
    size_t j = 0;
    while (j + 1 < pieces.size() && t >= piece_knots[j + 1]) ++j;
    if (j + 1 == pieces.size()) return pieces[j].coefficients;  // the hold
    return TaylorShift(pieces[j].coefficients, t0 - piece_knots[j]);
  };
  std::vector<PolynomialSegment> segments;
  for (size_t i = 0; i + 1 < unique.size(); ++i) {
    const double mid = 0.5 * (unique[i] + unique[i + 1]);
    PolynomialSegment seg;
    seg.duration_s = unique[i + 1] - unique[i];
    seg.coefficients[0] = {start.position_m.x()};
    seg.coefficients[1] = {start.position_m.y()};
    seg.coefficients[2] = coefficients(z, z_knots, mid, unique[i]);
    seg.coefficients[3] = coefficients(yaw, yaw_knots, mid, unique[i]);
    segments.push_back(std::move(seg));
  }
  return PiecewisePolynomialTrajectory::Create(start.time_s, std::move(segments), error);
}

}  // namespace kestrel

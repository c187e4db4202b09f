#include "exploration/trajectory_planner.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>

#include "common/check.h"

namespace kestrel {
namespace {

// A collision cell above this is known occupied (ALGORITHMS.md section 10's P > 0.5).
constexpr double kKnownOccupied = 0.5;

double Factorial(int n) {
  double f = 1.0;
  for (int i = 2; i <= n; ++i) f *= i;
  return f;
}

// i! / (i - d)!, 0 when i < d.
double Falling(int i, int d) {
  if (i < d) return 0.0;
  double f = 1.0;
  for (int j = 0; j < d; ++j) f *= i - j;
  return f;
}

double Binomial(int n, int k) { return Factorial(n) / (Factorial(k) * Factorial(n - k)); }

double DistancePointRect(const Eigen::Vector2d& p, const Eigen::Vector2d& lo,
                         const Eigen::Vector2d& hi) {
  const double dx = std::max({lo.x() - p.x(), 0.0, p.x() - hi.x()});
  const double dy = std::max({lo.y() - p.y(), 0.0, p.y() - hi.y()});
  return std::hypot(dx, dy);
}

double DistancePointSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  double t = len2 > 0.0 ? (p - a).dot(ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// Liang-Barsky: does [a, b] meet the closed rectangle?
bool SegmentMeetsRect(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& lo,
                      const Eigen::Vector2d& hi) {
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector2d d = b - a;
  for (int axis = 0; axis < 2; ++axis) {
    if (d[axis] == 0.0) {
      if (a[axis] < lo[axis] || a[axis] > hi[axis]) return false;
      continue;
    }
    double ta = (lo[axis] - a[axis]) / d[axis];
    double tb = (hi[axis] - a[axis]) / d[axis];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

double DistanceSegmentRect(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                           const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  if (SegmentMeetsRect(a, b, lo, hi)) return 0.0;
  double d = std::min(DistancePointRect(a, lo, hi), DistancePointRect(b, lo, hi));
  const Eigen::Vector2d corners[4] = {lo, hi, {lo.x(), hi.y()}, {hi.x(), lo.y()}};
  for (const auto& c : corners) d = std::min(d, DistancePointSegment(c, a, b));
  return d;
}

// Every cell whose square lies within radius of the segment [a, b] must be allowed.
bool CapsuleClear(const GridMap2D& g, const std::vector<bool>& allowed, const Eigen::Vector2d& a,
                  const Eigen::Vector2d& b, double r) {
  const double alpha = g.resolution_m;
  const Eigen::Vector2d lo = a.cwiseMin(b).array() - r;
  const Eigen::Vector2d hi = a.cwiseMax(b).array() + r;
  const int x0 = static_cast<int>(std::floor((lo.x() - g.origin_m.x()) / alpha));
  const int x1 = static_cast<int>(std::floor((hi.x() - g.origin_m.x()) / alpha));
  const int y0 = static_cast<int>(std::floor((lo.y() - g.origin_m.y()) / alpha));
  const int y1 = static_cast<int>(std::floor((hi.y() - g.origin_m.y()) / alpha));
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      const bool ok = g.Contains(x, y) && allowed[static_cast<size_t>(g.IndexOf(x, y))];
      if (ok) continue;
      const Eigen::Vector2d clo(g.origin_m.x() + x * alpha, g.origin_m.y() + y * alpha);
      const Eigen::Vector2d chi = clo.array() + alpha;
      if (DistanceSegmentRect(a, b, clo, chi) < r) return false;
    }
  }
  return true;
}

// Trapezoidal-profile duration of a rest-to-rest move of length L.
double TrapezoidDuration(double length_m, const TrajectoryConfig& c) {
  const double v = c.max_speed_mps, a = c.max_acceleration_mps2;
  const double t = length_m >= v * v / a ? length_m / v + v / a : 2.0 * std::sqrt(length_m / a);
  return std::max(t, c.min_segment_duration_s);
}

// Coefficients of the rest-to-rest smoothstep of degree 2k-1 on [0, 1], ascending powers.
std::vector<double> Smoothstep(int k) {
  if (k == 3) return {0, 0, 0, 10, -15, 6};
  return {0, 0, 0, 0, 35, -84, 70, -20};
}

double WrapAngle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a < 0) a += 2.0 * M_PI;
  return a - M_PI;
}

}  // namespace

void TrajectoryConfig::Validate() const {
  KESTREL_THROW_UNLESS(max_speed_mps > 0.0 && std::isfinite(max_speed_mps),
                       "max_speed_mps = " << max_speed_mps << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      max_acceleration_mps2 > 0.0 && std::isfinite(max_acceleration_mps2),
      "max_acceleration_mps2 = " << max_acceleration_mps2 << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(max_yaw_rate_radps > 0.0 && std::isfinite(max_yaw_rate_radps),
                       "max_yaw_rate_radps = " << max_yaw_rate_radps << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      derivative_order == 3 || derivative_order == 4,
      "derivative_order = " << derivative_order << ", accepted 3 (jerk) or 4 (snap)");
  KESTREL_THROW_UNLESS(sample_period_s > 0.0 && sample_period_s <= 1.0,
                       "sample_period_s = " << sample_period_s << ", accepted (0, 1]");
  KESTREL_THROW_UNLESS(vehicle_radius_m > 0.0 && std::isfinite(vehicle_radius_m),
                       "vehicle_radius_m = " << vehicle_radius_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      min_segment_duration_s > 0.0 && std::isfinite(min_segment_duration_s),
      "min_segment_duration_s = " << min_segment_duration_s << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(max_repair_rounds >= 0 && max_repair_rounds <= 50,
                       "max_repair_rounds = " << max_repair_rounds << ", accepted [0, 50]");
}

bool DiscClear(const GridMap2D& grid, const std::vector<bool>& allowed, const Eigen::Vector2d& p,
               double radius_m) {
  return CapsuleClear(grid, allowed, p, p, radius_m);
}

bool SegmentClear(const GridMap2D& grid, const std::vector<bool>& allowed, const Eigen::Vector2d& a,
                  const Eigen::Vector2d& b, double radius_m) {
  return CapsuleClear(grid, allowed, a, b, radius_m);
}

std::vector<Eigen::Vector2d> PruneWaypoints(const GridMap2D& grid, const std::vector<bool>& allowed,
                                            const std::vector<Eigen::Vector2d>& points,
                                            double radius_m) {
  std::vector<Eigen::Vector2d> out;
  if (points.empty()) return out;
  out.push_back(points.front());
  size_t i = 0;
  while (i + 1 < points.size()) {
    size_t j = points.size() - 1;
    while (j > i + 1 && !SegmentClear(grid, allowed, points[i], points[j], radius_m)) --j;
    out.push_back(points[j]);
    i = j;
  }
  return out;
}

bool RemainingPathClear(const PiecewisePolynomialTrajectory& trajectory, double from_time_s,
                        const GridMap2D& collision, const std::vector<bool>& allowed,
                        double radius_m, double sample_period_s) {
  KESTREL_THROW_UNLESS(sample_period_s > 0.0,
                       "RemainingPathClear: sample_period_s = " << sample_period_s);
  KESTREL_THROW_UNLESS(allowed.size() == collision.values.size(),
                       "RemainingPathClear: " << allowed.size() << " flags for "
                                              << collision.values.size() << " cells");
  const double t0 = std::max(from_time_s, trajectory.start_time_s());
  const double t1 = trajectory.end_time_s();
  const long steps = static_cast<long>(std::ceil((t1 - t0) / sample_period_s));
  for (long i = 0; i <= steps; ++i) {
    const double t = std::min(t0 + static_cast<double>(i) * sample_period_s, t1);
    if (!DiscClear(collision, allowed, trajectory.Evaluate(t).position_m.head<2>(), radius_m)) {
      return false;
    }
  }
  return true;
}

std::vector<bool> AllowedCells(const GridMap2D& collision, const std::vector<bool>& traversable,
                               const Eigen::Vector2d& start_xy, double radius_m) {
  std::vector<bool> allowed = traversable;
  const double a = collision.resolution_m;
  const int x0 =
      static_cast<int>(std::floor((start_xy.x() - radius_m - collision.origin_m.x()) / a));
  const int x1 =
      static_cast<int>(std::floor((start_xy.x() + radius_m - collision.origin_m.x()) / a));
  const int y0 =
      static_cast<int>(std::floor((start_xy.y() - radius_m - collision.origin_m.y()) / a));
  const int y1 =
      static_cast<int>(std::floor((start_xy.y() + radius_m - collision.origin_m.y()) / a));
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      if (collision.Contains(x, y)) allowed[static_cast<size_t>(collision.IndexOf(x, y))] = true;
    }
  }
  return allowed;
}

std::optional<std::vector<PolynomialSegment>> SolveMinimumDerivative(
    const std::vector<Eigen::Vector3d>& points, const std::vector<double>& durations_s,
    int derivative_order, const Eigen::Vector3d& start_velocity_mps,
    const std::vector<bool>& stop_at) {
  const int k = derivative_order;
  KESTREL_THROW_UNLESS(k == 3 || k == 4, "derivative_order = " << k << ", accepted 3 or 4");
  const int segments = static_cast<int>(durations_s.size());
  KESTREL_THROW_UNLESS(segments >= 1 && points.size() == durations_s.size() + 1,
                       "SolveMinimumDerivative: " << points.size() << " points, "
                                                  << durations_s.size() << " durations");
  for (double t : durations_s) {
    KESTREL_THROW_UNLESS(t > 0.0 && std::isfinite(t), "SolveMinimumDerivative: duration " << t);
  }
  KESTREL_THROW_UNLESS(stop_at.empty() || stop_at.size() == points.size(),
                       "SolveMinimumDerivative: " << stop_at.size() << " stop flags for "
                                                  << points.size() << " points");
  const auto stops = [&](int knot) {
    return !stop_at.empty() && stop_at[static_cast<size_t>(knot)];
  };
  const int nc = 2 * k;  // coefficients per segment (degree 2k - 1)
  const int nv = nc * segments;
  // Constraint count: positions 2S, start and end derivatives 1..k-1, interior knots.
  int ncons = 2 * segments + 2 * (k - 1);
  for (int s = 0; s + 1 < segments; ++s) ncons += stops(s + 1) ? 2 * (k - 1) : k;
  // The KKT matrix [2Q A^T; A 0] is sparse (banded by segment): built from triplets.
  std::vector<Eigen::Triplet<double>> entries;
  const auto put = [&](int r, int c, double v) {
    if (v == 0.0) return;
    entries.emplace_back(r, c, v);
    if (r >= nv) entries.emplace_back(c, r, v);  // A^T
  };
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(nv + ncons, 3);
  // Cost in normalised time sigma = tau / T: integral of (d^k p / dtau^k)^2 dtau
  // = T^(1 - 2k) integral_0^1 (d^k p / dsigma^k)^2 dsigma.
  for (int s = 0; s < segments; ++s) {
    const double scale = std::pow(durations_s[static_cast<size_t>(s)], 1 - 2 * k);
    for (int i = k; i < nc; ++i) {
      for (int j = k; j < nc; ++j) {
        put(s * nc + i, s * nc + j,
            2.0 * scale * Falling(i, k) * Falling(j, k) / static_cast<double>(i + j - 2 * k + 1));
      }
    }
  }
  int row = nv;
  // d-th derivative with respect to sigma at sigma (0 or 1) of segment s, into row r with factor f.
  const auto add_derivative = [&](int r, int s, int d, double sigma, double f) {
    for (int i = d; i < nc; ++i) {
      put(r, s * nc + i, f * Falling(i, d) * (sigma == 0.0 ? (i == d ? 1.0 : 0.0) : 1.0));
    }
  };
  for (int s = 0; s < segments; ++s) {
    add_derivative(row, s, 0, 0.0, 1.0);  // position at the segment's start
    rhs.row(row) = points[static_cast<size_t>(s)].transpose();
    ++row;
    add_derivative(row, s, 0, 1.0, 1.0);  // position at its end
    rhs.row(row) = points[static_cast<size_t>(s) + 1].transpose();
    ++row;
  }
  const double t_first = durations_s.front();
  for (int d = 1; d < k; ++d) {
    // Start: d-th time derivative = (1/T^d) d^d p/dsigma^d; velocity given, the rest zero.
    add_derivative(row, 0, d, 0.0, 1.0);
    if (d == 1) rhs.row(row) = (start_velocity_mps * t_first).transpose();
    ++row;
    add_derivative(row, segments - 1, d, 1.0, 1.0);  // rest at the goal
    ++row;
  }
  for (int s = 0; s + 1 < segments; ++s) {
    const double ta = durations_s[static_cast<size_t>(s)];
    const double tb = durations_s[static_cast<size_t>(s) + 1];
    if (stops(s + 1)) {
      for (int d = 1; d < k; ++d) {
        add_derivative(row++, s, d, 1.0, 1.0);
        add_derivative(row++, s + 1, d, 0.0, 1.0);
      }
    } else {
      // Continuity of derivatives 1..k: (1/ta^d) p_s^(d)(1) = (1/tb^d) p_(s+1)^(d)(0), times ta^d.
      for (int d = 1; d <= k; ++d) {
        add_derivative(row, s, d, 1.0, 1.0);
        add_derivative(row, s + 1, d, 0.0, -std::pow(ta / tb, d));
        ++row;
      }
    }
  }
  KESTREL_DEMAND(row == nv + ncons);
  Eigen::SparseMatrix<double> kkt(nv + ncons, nv + ncons);
  kkt.setFromTriplets(entries.begin(), entries.end());  // duplicates are summed
  kkt.makeCompressed();
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
  lu.compute(kkt);
  if (lu.info() != Eigen::Success) return std::nullopt;
  const Eigen::MatrixXd sol = lu.solve(rhs);
  if (lu.info() != Eigen::Success || !sol.allFinite() ||
      (kkt * sol - rhs).norm() / std::max(1.0, rhs.norm()) > 1e-8) {
    return std::nullopt;
  }
  std::vector<PolynomialSegment> out(static_cast<size_t>(segments));
  for (int s = 0; s < segments; ++s) {
    PolynomialSegment& seg = out[static_cast<size_t>(s)];
    const double t = durations_s[static_cast<size_t>(s)];
    seg.duration_s = t;
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double>& c = seg.coefficients[static_cast<size_t>(axis)];
      c.resize(static_cast<size_t>(nc));
      double tp = 1.0;
      for (int i = 0; i < nc; ++i) {
        c[static_cast<size_t>(i)] = sol(s * nc + i, axis) / tp;  // b_i / T^i
        tp *= t;
      }
    }
    seg.coefficients[3].assign(static_cast<size_t>(nc), 0.0);
  }
  return out;
}

TrajectoryPlan PlanTrajectory(const GridMap2D& collision, const std::vector<bool>& traversable,
                              const DistanceField& field, int goal_cell,
                              const Eigen::Vector3d& start_position_m,
                              const Eigen::Vector3d& start_velocity_mps, double start_yaw_rad,
                              double goal_yaw_rad, double height_m, double start_time_s,
                              const TrajectoryConfig& config) {
  config.Validate();
  KESTREL_THROW_UNLESS(traversable.size() == collision.values.size() &&
                           field.distance_m.size() == collision.values.size(),
                       "PlanTrajectory: map, flags and distance field sizes disagree");
  TrajectoryPlan plan;
  plan.cell_path = field.PathTo(goal_cell);
  if (plan.cell_path.empty()) {
    plan.error = "goal cell unreachable";
    return plan;
  }
  const double r = config.vehicle_radius_m;
  const Eigen::Vector2d start_xy = start_position_m.head<2>();
  // The cells under the start disc are allowed while leaving them; known-occupied ones only on
  // the pieces up to the start cell's centre (file comment).
  const std::vector<bool> allowed_leaving = AllowedCells(collision, traversable, start_xy, r);
  std::vector<bool> allowed = allowed_leaving;
  bool start_touches_occupied = false;
  const int start_cell = plan.cell_path.front();  // the vehicle's own cell stays allowed
  for (size_t i = 0; i < allowed.size(); ++i) {
    if (allowed[i] && !traversable[i] && collision.values[i] > kKnownOccupied &&
        static_cast<int>(i) != start_cell) {
      allowed[i] = false;
      start_touches_occupied = true;
    }
  }
  std::vector<Eigen::Vector2d> points{start_xy};
  for (int cell : plan.cell_path) points.push_back(collision.CenterOf(collision.CellAt(cell)));
  plan.unpruned_waypoints = static_cast<int>(points.size());
  // Leaving an occupied cell's margin: no pruning across the start cell's centre.
  std::vector<Eigen::Vector2d> way2;
  if (start_touches_occupied && points.size() > 2) {
    way2 = {points[0]};
    const std::vector<Eigen::Vector2d> rest(points.begin() + 1, points.end());
    for (const Eigen::Vector2d& p : PruneWaypoints(collision, allowed, rest, r)) way2.push_back(p);
  } else {
    way2 = PruneWaypoints(collision, allowed, points, r);
  }
  // Pieces checked against allowed_leaving: those before the start cell's centre.
  std::vector<bool> leaving(way2.size() > 1 ? way2.size() - 1 : 0, false);
  if (start_touches_occupied && !leaving.empty()) leaving[0] = true;

  const int k = config.derivative_order;
  const std::vector<double> step = Smoothstep(k);
  const double step_peak_rate = k == 4 ? 35.0 / 16.0 : 15.0 / 8.0;  // max s'(x)
  const double dyaw = WrapAngle(goal_yaw_rad - start_yaw_rad);
  std::vector<bool> stop_at(way2.size(), false);  // knots where the vehicle rests
  // The start velocity: only its component along the first leg, and no faster than the limit. A
  // minimum-snap piece that starts against or across its leg overshoots by several times the
  // start speed whatever its duration, so stretching time could never meet the speed limit.
  Eigen::Vector3d v0 = Eigen::Vector3d::Zero();
  if (way2.size() >= 2) {
    const Eigen::Vector2d leg = way2[1] - way2[0];
    if (leg.norm() > 1e-9) {
      const Eigen::Vector2d d = leg.normalized();
      const double along =
          std::clamp(start_velocity_mps.head<2>().dot(d), 0.0, 0.9 * config.max_speed_mps);
      v0.head<2>() = along * d;
    }
  }
  bool from_rest = v0.isZero();
  for (;;) {
    std::vector<Eigen::Vector3d> way3;
    for (size_t i = 0; i < way2.size(); ++i) {
      way3.emplace_back(way2[i].x(), way2[i].y(), i == 0 ? start_position_m.z() : height_m);
    }
    std::vector<double> durations;
    for (size_t i = 0; i + 1 < way3.size(); ++i) {
      durations.push_back(TrapezoidDuration((way3[i + 1] - way3[i]).norm(), config));
    }
    std::optional<PiecewisePolynomialTrajectory> traj;
    // Stretching time lowers speed and acceleration as 1/T and 1/T^2 from rest, but not with a
    // start velocity (the piece overshoots by about v0 T): past this bound on the total duration
    // (and before sampling a huge trajectory) give up and start from rest instead.
    double unscaled_total_s = 0.0;
    for (double t : durations) unscaled_total_s += t;
    const double max_total_s = 16.0 * unscaled_total_s + 60.0;
    for (int scaling = 0; scaling < 12; ++scaling) {
      traj.reset();
      double total = 0.0;
      for (double t : durations) total += t;
      if (total > max_total_s) break;  // not converging
      const double yaw_time = step_peak_rate * std::abs(dyaw) / config.max_yaw_rate_radps;
      if (total < yaw_time) {
        for (double& t : durations) t *= yaw_time / total * 1.0001;
        total = yaw_time * 1.0001;
      }
      std::optional<std::vector<PolynomialSegment>> segs =
          SolveMinimumDerivative(way3, durations, k, v0, stop_at);
      if (!segs) {
        plan.error = "KKT system could not be solved";
        return plan;
      }
      // Yaw: psi0 + dpsi * s(t / total), re-expanded in each segment's local time.
      double t0 = 0.0;
      for (PolynomialSegment& seg : *segs) {
        std::vector<double>& c = seg.coefficients[3];
        c.assign(step.size(), 0.0);
        for (size_t i = 0; i < step.size(); ++i) {
          for (size_t m = 0; m <= i; ++m) {
            c[m] += dyaw * step[i] * Binomial(static_cast<int>(i), static_cast<int>(m)) *
                    std::pow(t0, static_cast<double>(i - m)) /
                    std::pow(total, static_cast<double>(i));
          }
        }
        c[0] += start_yaw_rad;
        t0 += seg.duration_s;
      }
      std::string error;
      traj = PiecewisePolynomialTrajectory::Create(start_time_s, *segs, &error);
      if (!traj) {
        plan.error = "invalid trajectory: " + error;
        return plan;
      }
      double v_max = 0.0, a_max = 0.0;
      for (const TrajectorySample& s : traj->Sample(config.sample_period_s)) {
        v_max = std::max(v_max, s.flat.velocity_mps.norm());
        a_max = std::max(a_max, s.flat.acceleration_mps2.norm());
      }
      const double factor =
          std::max(v_max / config.max_speed_mps, std::sqrt(a_max / config.max_acceleration_mps2));
      if (factor <= 1.0) break;
      if (scaling == 11) traj.reset();                 // did not converge
      for (double& t : durations) t *= factor * 1.01;  // v ~ 1/T, a ~ 1/T^2
    }
    if (!traj.has_value()) {
      if (!from_rest) {  // start from rest instead (the controller absorbs the step in velocity)
        v0.setZero();
        from_rest = true;
        continue;
      }
      plan.error = "time allocation did not meet the speed and acceleration limits";
      return plan;
    }
    // Check the disc at every sample; collect the pieces that leave the allowed cells.
    std::vector<bool> bad(durations.size(), false);
    bool any_bad = false;
    for (const TrajectorySample& s : traj->Sample(config.sample_period_s)) {
      double t = s.time_s - start_time_s;
      size_t seg = 0;
      while (seg + 1 < durations.size() && t > durations[seg]) t -= durations[seg++];
      if (DiscClear(collision, leaving[seg] ? allowed_leaving : allowed,
                    s.flat.position_m.head<2>(), r)) {
        continue;
      }
      bad[seg] = true;
      any_bad = true;
    }
    if (!any_bad) {
      plan.trajectory = std::move(traj);
      plan.waypoints = way3;
      plan.stop_waypoints = static_cast<int>(std::count(stop_at.begin(), stop_at.end(), true));
      return plan;
    }
    if (plan.repair_rounds < config.max_repair_rounds) {
      // Repair: the midpoint of a line-of-sight-checked straight segment is a safe waypoint.
      std::vector<Eigen::Vector2d> repaired{way2.front()};
      std::vector<bool> repaired_stop{stop_at.front()};
      std::vector<bool> repaired_leaving;
      for (size_t i = 0; i + 1 < way2.size(); ++i) {
        if (bad[i]) {
          repaired.push_back(0.5 * (way2[i] + way2[i + 1]));
          repaired_stop.push_back(false);
          repaired_leaving.push_back(leaving[i]);  // both halves keep the piece's rule
        }
        repaired.push_back(way2[i + 1]);
        repaired_stop.push_back(stop_at[i + 1]);
        repaired_leaving.push_back(leaving[i]);
      }
      way2 = repaired;
      stop_at = repaired_stop;
      leaving = repaired_leaving;
      ++plan.repair_rounds;
      continue;
    }
    // Then rest at both ends of every failing piece: a piece between two rests is straight.
    bool changed = false;
    for (size_t i = 0; i < bad.size(); ++i) {
      if (!bad[i]) continue;
      for (size_t knot : {i, i + 1}) {
        if (knot == 0 || knot + 1 == way2.size() || stop_at[knot]) continue;
        stop_at[knot] = true;
        changed = true;
      }
    }
    if (!changed) {
      plan.error = "sampled trajectory leaves the traversable cells even with rests at waypoints";
      return plan;
    }
  }
}

}  // namespace kestrel

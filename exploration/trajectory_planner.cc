#include "exploration/trajectory_planner.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "common/check.h"

namespace kestrel {
namespace {

// A collision cell above this is known occupied (docs/algorithms.md §12.2's P > 0.5).
constexpr double kKnownOccupied = 0.5;

// i! / (i - d)!, 0 when i < d.
double Falling(int i, int d) {
  if (i < d) return 0.0;
  double f = 1.0;
  for (int j = 0; j < d; ++j) f *= i - j;
  return f;
}

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

double WrapAngle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a < 0) a += 2.0 * M_PI;
  return a - M_PI;
}

// Longest piece of a leg, as a time at max_speed: longer legs are split so that the polynomial
// follows the speed profile (file comment step 3; 1 s pieces overshot the profile's speed by 12%
// on a 10 m straight, 0.5 s pieces by 1%).
constexpr double kMaxPieceTime_s = 0.5;
// No added point within this time at max_speed of a turn or of the start: the polynomial needs
// room there to turn its velocity (step 3).
constexpr double kTurnFreeTime_s = 1.0;
// The window around a turning waypoint over which the velocity turns, as a fraction of d (the
// shorter half-leg, at most kTurnFreeTime_s at max_speed): the polynomial, pinned at the waypoint,
// turns its velocity within about d / 8 on either side (measured on a 90 deg corner at 1 m/s and
// 1 m/s^2: peak acceleration 0.98 of the limit after the profile's refinement).
constexpr double kTurnWindowFraction = 1.0 / 8.0;
// The profile accelerates at this fraction of max_acceleration: a speed change along a cubic
// smoothstep with peak acceleration max_acceleration takes the time and distance of a constant
// acceleration of 2/3 of it, and the polynomial follows such a smooth change closely.
constexpr double kProfileAcceleration = 2.0 / 3.0;
// Rounds in which the profile's speed and acceleration are lowered by the sampled overshoot
// before the uniform scaling of the safety net.
constexpr int kProfileRefinements = 3;
// The yaw acceleration bound, per unit of max_yaw_rate (1/s): a change of the yaw rate by
// max_yaw_rate takes 1.5 / 2 = 0.75 s (cubic smoothstep of the rate, step 5).
constexpr double kYawAccelerationPerRate = 2.0;

// Speed limit at waypoint b where the path a-b-c turns (step 3): the velocity (speed v) turns by
// the angle theta between the legs while the vehicle covers 2 w, w = kTurnWindowFraction d with d
// = half the shorter leg, at most kTurnFreeTime_s at max speed; its mean lateral acceleration
// 2 v sin(theta / 2) / (2 w / v) must not exceed max_acceleration:
//     v <= sqrt(max_acceleration w / sin(theta / 2)),
// capped at max_speed: 0 for a U-turn (0.42 m/s for 90 deg at 1 m/s^2 with d = 1 m).
double TurnSpeed(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                 const TrajectoryConfig& config) {
  const Eigen::Vector2d in = b - a, out = c - b;
  if (in.norm() < 1e-9 || out.norm() < 1e-9) return 0.0;
  const double cos_theta = std::clamp(in.normalized().dot(out.normalized()), -1.0, 1.0);
  const double sin_half = std::sqrt(0.5 * (1.0 - cos_theta));
  if (sin_half < 1e-9) return config.max_speed_mps;
  const double d =
      std::min({0.5 * in.norm(), 0.5 * out.norm(), config.max_speed_mps * kTurnFreeTime_s});
  const double window_m = kTurnWindowFraction * d;
  return std::min(config.max_speed_mps,
                  std::sqrt(config.max_acceleration_mps2 * window_m / sin_half));
}

// Time to cover length_m from speed v0 to v1 (step 3): accelerate at c.max_acceleration (the
// profile's) up to a peak (at most c.max_speed), cruise, decelerate; where the ends are too far
// apart for the length (only from a fixed start speed), the constant acceleration between them.
// At least min_segment_duration_s.
double PieceTime(double length_m, double v0, double v1, const TrajectoryConfig& c) {
  const double a = c.max_acceleration_mps2;
  double t = 0.0;
  if (length_m > 0.0) {
    if (std::abs(v1 * v1 - v0 * v0) >= 2.0 * a * length_m) {
      t = 2.0 * length_m / (v0 + v1);
    } else {
      // (v0 above max_speed, from a fast start, first slows down to it.)
      const double peak =
          std::min(c.max_speed_mps, std::sqrt(a * length_m + 0.5 * (v0 * v0 + v1 * v1)));
      const double ramps_m =
          (std::abs(peak * peak - v0 * v0) + std::abs(peak * peak - v1 * v1)) / (2.0 * a);
      t = (std::abs(peak - v0) + std::abs(peak - v1)) / a +
          std::max(0.0, length_m - ramps_m) / peak;
    }
  }
  return std::max(t, c.min_segment_duration_s);
}

// Piece durations from the speed profile along the polyline (step 3): speed caps[i] at point i
// (caps[0] unused, the last one 0: rest at the goal), a forward pass from start_speed with
// max_acceleration, a backward pass from the goal's rest, max_speed everywhere.
std::vector<double> ProfileDurations(const std::vector<Eigen::Vector3d>& points,
                                     const std::vector<double>& caps, double start_speed,
                                     const TrajectoryConfig& c) {
  const size_t n = points.size();
  const double a = c.max_acceleration_mps2;
  std::vector<double> length(n - 1), v(n);
  for (size_t i = 0; i + 1 < n; ++i) length[i] = (points[i + 1] - points[i]).norm();
  v[0] = start_speed;  // fixed: the vehicle already flies at it
  for (size_t i = 0; i + 1 < n; ++i) {
    v[i + 1] = std::min({caps[i + 1], c.max_speed_mps, std::sqrt(v[i] * v[i] + 2 * a * length[i])});
  }
  v[n - 1] = 0.0;
  for (size_t i = n - 1; i-- > 1;) {
    v[i] = std::min(v[i], std::sqrt(v[i + 1] * v[i + 1] + 2 * a * length[i]));
  }
  std::vector<double> durations(n - 1);
  for (size_t i = 0; i + 1 < n; ++i) durations[i] = PieceTime(length[i], v[i], v[i + 1], c);
  return durations;
}

}  // namespace

// Step 5 of the file comment; the yaw acceleration is at most kYawAccelerationPerRate max_rate.
std::vector<YawPiece> YawProfile(double yaw0, double rate0, double delta, double max_rate) {
  const double alpha = kYawAccelerationPerRate * max_rate;
  const auto ramp_s = [alpha](double from, double to) { return 1.5 * std::abs(to - from) / alpha; };
  // The angle swept by the ramps rate0 -> peak -> 0 (no cruise): non-decreasing in peak.
  const auto swept = [&](double peak) {
    return 0.5 * (rate0 + peak) * ramp_s(rate0, peak) + 0.5 * peak * ramp_s(peak, 0.0);
  };
  double peak = 0.0, cruise_s = 0.0;
  if (delta >= swept(max_rate)) {
    peak = max_rate;
    cruise_s = (delta - swept(max_rate)) / max_rate;
  } else if (delta <= swept(-max_rate)) {
    peak = -max_rate;
    cruise_s = (swept(-max_rate) - delta) / max_rate;
  } else {
    double lo = -max_rate, hi = max_rate;
    for (int i = 0; i < 200 && hi - lo > 1e-15; ++i) {
      const double mid = 0.5 * (lo + hi);
      (swept(mid) < delta ? lo : hi) = mid;
    }
    peak = 0.5 * (lo + hi);
  }
  std::vector<YawPiece> pieces;
  double yaw = yaw0;
  const auto ramp = [&](double from, double to) {
    const double t = ramp_s(from, to);
    if (t < 1e-9) return;
    // rate = from + (to - from)(3 x^2 - 2 x^3), x = tau / t, integrated.
    pieces.push_back(
        {t, {yaw, from, 0.0, (to - from) / (t * t), -(to - from) / (2.0 * t * t * t)}});
    yaw += 0.5 * (from + to) * t;
  };
  ramp(rate0, peak);
  if (cruise_s > 1e-9) {
    pieces.push_back({cruise_s, {yaw, peak}});
    yaw += peak * cruise_s;
  }
  ramp(peak, 0.0);
  pieces.push_back({0.0, {yaw}});  // the hold (its duration unused)
  return pieces;
}

namespace {

// The final trajectory (step 5): the translation pieces (a hover at the goal appended when the
// turn outlasts them) and the yaw profile, both split at the union of their knots by Taylor
// shifts. knot_points gets the position at every knot: way3 at the translation's knots.
std::optional<PiecewisePolynomialTrajectory> WithYaw(
    const std::vector<PolynomialSegment>& translation, const std::vector<Eigen::Vector3d>& way3,
    const TrajectoryStart& start, double goal_yaw_rad, const TrajectoryConfig& config,
    std::vector<Eigen::Vector3d>* knot_points, double* yaw_duration_s) {
  const std::vector<YawPiece> yaw =
      YawProfile(start.yaw_rad, start.yaw_rate_radps, WrapAngle(goal_yaw_rad - start.yaw_rad),
                 config.max_yaw_rate_radps);
  std::vector<double> yaw_knots{0.0};
  for (size_t j = 0; j + 1 < yaw.size(); ++j)
    yaw_knots.push_back(yaw_knots.back() + yaw[j].duration_s);
  *yaw_duration_s = yaw_knots.back();
  std::vector<PolynomialSegment> moves = translation;
  std::vector<Eigen::Vector3d> points = way3;
  std::vector<double> move_knots{0.0};
  for (const PolynomialSegment& m : moves) move_knots.push_back(move_knots.back() + m.duration_s);
  if (yaw_knots.back() > move_knots.back() + 1e-6) {  // hover at the goal while turning
    PolynomialSegment hover;
    hover.duration_s = yaw_knots.back() - move_knots.back();
    for (int axis = 0; axis < 3; ++axis)
      hover.coefficients[static_cast<size_t>(axis)] = {way3.back()[axis]};
    moves.push_back(hover);
    points.push_back(way3.back());
    move_knots.push_back(yaw_knots.back());
  }
  // Knots: the translation's (index into points) and the yaw profile's not within 1e-6 s of one.
  std::vector<std::pair<double, int>> knots;
  for (size_t i = 0; i < move_knots.size(); ++i)
    knots.emplace_back(move_knots[i], static_cast<int>(i));
  for (double t : yaw_knots) {
    bool near = false;
    for (double m : move_knots) near = near || std::abs(t - m) < 1e-6;
    if (!near && t < move_knots.back()) knots.emplace_back(t, -1);
  }
  std::sort(knots.begin(), knots.end());
  // The piece of a profile (knot times `at`) containing time t.
  const auto piece_of = [](const std::vector<double>& at, double t) {
    const auto it = std::upper_bound(at.begin(), at.end(), t);
    return static_cast<size_t>(std::max<std::ptrdiff_t>(0, it - at.begin() - 1));
  };
  std::vector<PolynomialSegment> pieces;
  knot_points->clear();
  for (size_t q = 0; q + 1 < knots.size(); ++q) {
    const double t0 = knots[q].first, t1 = knots[q + 1].first;
    const double mid = 0.5 * (t0 + t1);
    const size_t m = std::min(piece_of(move_knots, mid), moves.size() - 1);
    const size_t j = std::min(piece_of(yaw_knots, mid), yaw.size() - 1);
    PolynomialSegment piece;
    piece.duration_s = t1 - t0;
    for (size_t axis = 0; axis < 3; ++axis) {
      piece.coefficients[axis] = TaylorShift(moves[m].coefficients[axis], t0 - move_knots[m]);
    }
    piece.coefficients[3] = TaylorShift(yaw[j].coefficients, t0 - yaw_knots[j]);
    if (knots[q].second >= 0) {
      knot_points->push_back(points[static_cast<size_t>(knots[q].second)]);
    } else {
      knot_points->emplace_back(piece.coefficients[0][0], piece.coefficients[1][0],
                                piece.coefficients[2][0]);
    }
    pieces.push_back(std::move(piece));
  }
  knot_points->push_back(points.back());
  return PiecewisePolynomialTrajectory::Create(start.time_s, std::move(pieces), nullptr);
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

namespace {
// How far p lies across a passage from its cell's path point (nullopt where its cell has none):
// along the passage's normal (path_across) or, without one, the point is on a cell edge, the
// passage runs along that edge, and the offset is measured along the edge's normal.
std::optional<double> PassageOffset(const PathClearance& room, const GridMap2D& grid,
                                    const Eigen::Vector2d& p) {
  if (room.path_points == nullptr) return std::nullopt;
  const std::optional<Cell2> c = grid.CellOf(p);
  if (!c) return std::nullopt;
  const int cell = grid.IndexOf(*c);
  const auto it = room.path_points->find(cell);
  if (it == room.path_points->end()) return std::nullopt;
  const Eigen::Vector2d& q = it->second;
  if (room.path_across != nullptr) {
    const auto across = room.path_across->find(cell);
    if (across != room.path_across->end()) return std::abs((p - q).dot(across->second.normal));
  }
  const double u = (q.x() - grid.origin_m.x()) / grid.resolution_m;
  const bool on_x_edge =
      std::abs(u - std::round(u)) < 0.25;  // a cell boundary in x: a vertical edge
  return on_x_edge ? std::abs(p.x() - q.x()) : std::abs(p.y() - q.y());
}

// Whether p keeps within its passage cell's tolerance across the passage (true outside
// passages).
bool WithinPassage(const PathClearance& room, const GridMap2D& grid, const Eigen::Vector2d& p) {
  const std::optional<double> offset = PassageOffset(room, grid, p);
  if (!offset) return true;
  double tolerance = 0.5 * grid.resolution_m;
  if (room.path_across != nullptr) {
    const std::optional<Cell2> c = grid.CellOf(p);
    const auto across = room.path_across->find(grid.IndexOf(*c));
    if (across != room.path_across->end()) tolerance = across->second.tolerance_m;
  }
  return *offset <= tolerance + 1e-9;
}

// The clearance at p (0 outside the map): its cell's; in a cell with a path point (a passage),
// the point's clearance less p's offset across the passage, so that shortcuts keep to its middle.
double ClearanceAt(const PathClearance& room, const Eigen::Vector2d& p) {
  const GridMap2D& clearance = *room.clearance;
  const std::optional<Cell2> c = clearance.CellOf(p);
  if (!c) return 0.0;
  return clearance.at(c->x, c->y) - PassageOffset(room, clearance, p).value_or(0.0);
}

// The least clearance along [a, b], sampled every quarter cell, its ends included.
double SegmentClearance(const PathClearance& room, const Eigen::Vector2d& a,
                        const Eigen::Vector2d& b) {
  const int steps = std::max(
      1, static_cast<int>(std::ceil((b - a).norm() / (0.25 * room.clearance->resolution_m))));
  double least = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= steps; ++k) {
    least = std::min(least, ClearanceAt(room, a + (b - a) * (static_cast<double>(k) / steps)));
  }
  return least;
}
}  // namespace

namespace {
// Whether [a, b], sampled every quarter cell (its ends included), keeps within every passage's
// tolerance (WithinPassage).
bool SegmentWithinPassages(const GridMap2D& grid, const PathClearance& room,
                           const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  if (room.path_points == nullptr || room.path_points->empty()) return true;
  const int steps =
      std::max(1, static_cast<int>(std::ceil((b - a).norm() / (0.25 * grid.resolution_m))));
  for (int k = 0; k <= steps; ++k) {
    if (!WithinPassage(room, grid, a + (b - a) * (static_cast<double>(k) / steps))) return false;
  }
  return true;
}
}  // namespace

std::vector<Eigen::Vector2d> PruneWaypoints(const GridMap2D& grid, const std::vector<bool>& allowed,
                                            const std::vector<Eigen::Vector2d>& points,
                                            double radius_m, const PathClearance& clearance) {
  std::vector<Eigen::Vector2d> out;
  if (points.empty()) return out;
  const GridMap2D* room = clearance.clearance;
  // Per point, its clearance (with `clearance` only).
  std::vector<double> at;
  if (room != nullptr) {
    for (const Eigen::Vector2d& p : points) at.push_back(ClearanceAt(clearance, p));
  }
  out.push_back(points.front());
  size_t i = 0;
  while (i + 1 < points.size()) {
    // least[j]: the least clearance of points i..j (with `clearance` only).
    std::vector<double> least;
    if (room != nullptr) {
      least.assign(points.size(), 0.0);
      least[i] = at[i];
      for (size_t j = i + 1; j < points.size(); ++j) least[j] = std::min(least[j - 1], at[j]);
    }
    const auto keeps_room = [&](size_t j) {
      if (!SegmentWithinPassages(grid, clearance, points[i], points[j])) return false;
      if (room == nullptr) return true;
      const double need = std::min(clearance.preferred_m, least[j]) - 0.5 * room->resolution_m;
      return SegmentClearance(clearance, points[i], points[j]) >= need;
    };
    size_t j = points.size() - 1;
    while (j > i + 1 &&
           !(SegmentClear(grid, allowed, points[i], points[j], radius_m) && keeps_room(j))) {
      --j;
    }
    out.push_back(points[j]);
    i = j;
  }
  return out;
}

std::optional<PiecewisePolynomialTrajectory> PlanStop(const TrajectoryStart& start,
                                                      const TrajectoryConfig& config) {
  config.Validate();
  if (!start.position_m.allFinite() || !start.velocity_mps.allFinite() ||
      !start.acceleration_mps2.allFinite() || !std::isfinite(start.yaw_rad) ||
      !std::isfinite(start.yaw_rate_radps) || !std::isfinite(start.time_s)) {
    return std::nullopt;
  }
  const Eigen::Vector3d& v0 = start.velocity_mps;
  const double limit = std::max(config.max_acceleration_mps2, start.acceleration_mps2.norm());
  // A constant deceleration at the limit takes |v0| / a and v0 T / 2 of way; the polynomial's
  // peak is higher, so T grows from there by 10% at a time.
  double duration = std::max(config.min_segment_duration_s, v0.norm() / limit);
  for (int attempt = 0; attempt < 60; ++attempt, duration *= 1.1) {
    const std::vector<Eigen::Vector3d> points{start.position_m,
                                              start.position_m + 0.5 * duration * v0};
    std::optional<std::vector<PolynomialSegment>> segs = SolveMinimumDerivative(
        points, {duration}, config.derivative_order, v0, start.acceleration_mps2);
    if (!segs) return std::nullopt;
    // Yaw: psi0 + omega0 tau - omega0 tau^2 / (2 T), the rate falling linearly to 0.
    segs->front().coefficients[3] = {start.yaw_rad, start.yaw_rate_radps,
                                     -start.yaw_rate_radps / (2.0 * duration)};
    std::optional<PiecewisePolynomialTrajectory> stop =
        PiecewisePolynomialTrajectory::Create(start.time_s, *segs, nullptr);
    if (!stop) return std::nullopt;
    double peak = 0.0;
    for (const TrajectorySample& s : stop->Sample(config.sample_period_s)) {
      peak = std::max(peak, s.flat.acceleration_mps2.norm());
    }
    if (peak <= limit * (1.0 + 1e-9)) return stop;
  }
  return std::nullopt;
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

namespace {

// SolveMinimumDerivative with the start constrained in velocity and acceleration and, when
// !start_jerk_free, zero derivatives 3..k-1 (the jerk for k = 4).
std::optional<std::vector<PolynomialSegment>> SolveMinimumDerivativeFrom(
    const std::vector<Eigen::Vector3d>& points, const std::vector<double>& durations_s,
    int derivative_order, const Eigen::Vector3d& start_velocity_mps,
    const Eigen::Vector3d& start_acceleration_mps2, bool start_jerk_free,
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
  // The start's constrained derivatives: 1..k-1, or 1..2 with the jerk free.
  const int start_orders = start_jerk_free ? std::min(2, k - 1) : k - 1;
  // Constraint count: positions 2S, start and end derivatives, interior knots.
  int ncons = 2 * segments + start_orders + (k - 1);
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
  for (int d = 1; d <= start_orders; ++d) {
    // Start: d-th time derivative = (1/T^d) d^d p/dsigma^d; velocity and acceleration given, the
    // rest zero.
    add_derivative(row, 0, d, 0.0, 1.0);
    if (d == 1) rhs.row(row) = (start_velocity_mps * t_first).transpose();
    if (d == 2) rhs.row(row) = (start_acceleration_mps2 * t_first * t_first).transpose();
    ++row;
  }
  for (int d = 1; d < k; ++d) add_derivative(row++, segments - 1, d, 1.0, 1.0);  // rest at goal
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
  Eigen::MatrixXd sol = lu.solve(rhs);
  // Two rounds of iterative refinement: the cost's entries (up to about 1e5 / T^7) and the
  // constraints' (up to 5040) differ by orders of magnitude, and with the start's jerk free the
  // cost shapes even a single piece.
  for (int round = 0; round < 2 && lu.info() == Eigen::Success && sol.allFinite(); ++round) {
    sol += lu.solve(rhs - kkt * sol);
  }
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

}  // namespace

std::optional<std::vector<PolynomialSegment>> SolveMinimumDerivative(
    const std::vector<Eigen::Vector3d>& points, const std::vector<double>& durations_s,
    int derivative_order, const Eigen::Vector3d& start_velocity_mps,
    const std::vector<bool>& stop_at) {
  return SolveMinimumDerivativeFrom(points, durations_s, derivative_order, start_velocity_mps,
                                    Eigen::Vector3d::Zero(), false, stop_at);
}

std::optional<std::vector<PolynomialSegment>> SolveMinimumDerivative(
    const std::vector<Eigen::Vector3d>& points, const std::vector<double>& durations_s,
    int derivative_order, const Eigen::Vector3d& start_velocity_mps,
    const Eigen::Vector3d& start_acceleration_mps2, const std::vector<bool>& stop_at) {
  return SolveMinimumDerivativeFrom(points, durations_s, derivative_order, start_velocity_mps,
                                    start_acceleration_mps2, true, stop_at);
}

TrajectoryPlan PlanTrajectory(const GridMap2D& collision, const std::vector<bool>& traversable,
                              const DistanceField& field, int goal_cell,
                              const TrajectoryStart& start, double goal_yaw_rad, double height_m,
                              const TrajectoryConfig& config, const PathClearance& clearance) {
  config.Validate();
  KESTREL_THROW_UNLESS(traversable.size() == collision.values.size() &&
                           field.distance_m.size() == collision.values.size(),
                       "PlanTrajectory: map, flags and distance field sizes disagree");
  KESTREL_THROW_UNLESS(start.position_m.allFinite() && start.velocity_mps.allFinite() &&
                           start.acceleration_mps2.allFinite() && std::isfinite(start.yaw_rad) &&
                           std::isfinite(start.yaw_rate_radps) && std::isfinite(start.time_s) &&
                           std::isfinite(goal_yaw_rad) && std::isfinite(height_m),
                       "PlanTrajectory: start state, goal yaw or height not finite");
  TrajectoryPlan plan;
  plan.cell_path = field.PathTo(goal_cell);
  if (plan.cell_path.empty()) {
    plan.error = "goal cell unreachable";
    return plan;
  }
  const double r = config.vehicle_radius_m;
  const Eigen::Vector2d start_xy = start.position_m.head<2>();
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
  // Where the path crosses each cell: its centre, or its passage point (PathClearance).
  const auto path_point = [&](int cell) -> Eigen::Vector2d {
    if (clearance.path_points != nullptr) {
      const auto it = clearance.path_points->find(cell);
      if (it != clearance.path_points->end()) return it->second;
    }
    return collision.CenterOf(collision.CellAt(cell));
  };
  for (int cell : plan.cell_path) points.push_back(path_point(cell));
  plan.unpruned_waypoints = static_cast<int>(points.size());
  // Leaving an occupied cell's margin: no pruning across the start cell's centre.
  std::vector<Eigen::Vector2d> way2;
  if (start_touches_occupied && points.size() > 2) {
    way2 = {points[0]};
    const std::vector<Eigen::Vector2d> rest(points.begin() + 1, points.end());
    for (const Eigen::Vector2d& p : PruneWaypoints(collision, allowed, rest, r, clearance)) {
      way2.push_back(p);
    }
  } else {
    way2 = PruneWaypoints(collision, allowed, points, r, clearance);
  }
  // Pieces checked against allowed_leaving: those before the start cell's centre.
  std::vector<bool> leaving(way2.size() > 1 ? way2.size() - 1 : 0, false);
  if (start_touches_occupied && !leaving.empty()) leaving[0] = true;

  const int k = config.derivative_order;
  const double v_max = config.max_speed_mps;
  // Step 3: turn-limited speeds at the pruned polyline's interior waypoints, rest at the goal;
  // long legs split into pieces (the speed profile's samples) carrying the leg's flag, the added
  // points without a turn.
  std::vector<Eigen::Vector2d> base_way{way2.front()};
  std::vector<double> base_cap{v_max};  // the start's entry is not used
  std::vector<bool> base_leaving;
  const double max_piece_m = v_max * kMaxPieceTime_s;
  const double free_m = v_max * kTurnFreeTime_s;
  const auto turns = [&](size_t i) {  // does the polyline turn at way2[i] (the start: always)?
    if (i == 0) return true;
    if (i + 1 >= way2.size()) return false;
    const Eigen::Vector2d in = way2[i] - way2[i - 1], out = way2[i + 1] - way2[i];
    return in.norm() < 1e-9 || out.norm() < 1e-9 ||
           in.normalized().dot(out.normalized()) < 1.0 - 1e-9;
  };
  for (size_t i = 0; i + 1 < way2.size(); ++i) {
    const Eigen::Vector2d leg = way2[i + 1] - way2[i];
    const double length = leg.norm();
    const Eigen::Vector2d u =
        length > 1e-9 ? Eigen::Vector2d(leg / length) : Eigen::Vector2d::Zero();
    // Arc lengths of the added points: none within free_m of a turn (or of the start), so that
    // the polynomial has room to turn the velocity there; pieces of at most max_piece_m between.
    const double f0 = turns(i) ? std::min(free_m, 0.5 * length) : 0.0;
    const double f1 = turns(i + 1) ? std::min(free_m, 0.5 * length) : 0.0;
    // (None on a leg no longer than its free lengths and one piece.)
    std::vector<double> at;
    const double middle = length - f0 - f1;
    if (middle > max_piece_m) {
      if (f0 > 0.0) at.push_back(f0);
      const int pieces = static_cast<int>(std::ceil(middle / max_piece_m - 1e-9));
      for (int j = 1; j < pieces; ++j) at.push_back(f0 + middle * j / pieces);
      if (f1 > 0.0) at.push_back(length - f1);
    }
    for (double a : at) {
      if (a <= 1e-9 || a >= length - 1e-9) continue;
      base_way.push_back(way2[i] + a * u);
      base_cap.push_back(v_max);
      base_leaving.push_back(leaving[i]);
    }
    base_way.push_back(way2[i + 1]);
    base_cap.push_back(i + 2 < way2.size() ? TurnSpeed(way2[i], way2[i + 1], way2[i + 2], config)
                                           : 0.0);
    base_leaving.push_back(leaving[i]);
  }
  // The start: exactly the given state first. Should the limits or the disc check fail with it
  // (typically a velocity pointing away from the new path), the same state with a run-out: the
  // vehicle first comes to rest on a straight line along its velocity (the distance of a stop at
  // the profile's deceleration, if that segment is clear), then follows the path from there, so
  // the set point stays continuous in position, velocity and acceleration. Then its velocity's
  // component along the first leg (no faster than 0.9 max_speed, zero acceleration: a
  // minimum-snap piece that starts against or across its leg overshoots by several times the
  // start speed whatever its duration), then rest (the controller absorbs the step in velocity:
  // a hard manoeuvre, the last resort).
  struct StartTry {
    Eigen::Vector3d velocity;
    Eigen::Vector3d acceleration;
    std::vector<Eigen::Vector2d> run_out;  // rest points ahead of base_way[1..]; empty: none
  };
  std::vector<StartTry> starts{{start.velocity_mps, start.acceleration_mps2, {}}};
  {
    const Eigen::Vector2d v = start.velocity_mps.head<2>();
    const double speed = v.norm();
    // The stop at the profile's deceleration, then longer ones: an acceleration at the start
    // that still pushes forward (or sideways) needs more room to turn around.
    const double base_m =
        speed * speed / (2.0 * kProfileAcceleration * config.max_acceleration_mps2) + 0.05;
    for (const double scale : {1.0, 1.6, 2.5}) {
      if (speed <= 0.05) break;  // at rest: nothing to run out
      const Eigen::Vector2d stop = start_xy + scale * base_m * (v / speed);
      if (!SegmentClear(collision, allowed, start_xy, stop, r)) break;
      StartTry run_out{start.velocity_mps, start.acceleration_mps2, {stop}};
      // Back to the start of the path when the straight line from the stop to it is not clear.
      if (base_way.size() > 1 && !SegmentClear(collision, allowed, stop, base_way[1], r)) {
        run_out.run_out.push_back(start_xy);
      }
      starts.push_back(run_out);
    }
  }
  {
    Eigen::Vector3d along = Eigen::Vector3d::Zero();
    const Eigen::Vector2d leg = base_way[1] - base_way[0];
    if (leg.norm() > 1e-9) {
      const Eigen::Vector2d d = leg.normalized();
      along.head<2>() = std::clamp(start.velocity_mps.head<2>().dot(d), 0.0, 0.9 * v_max) * d;
    }
    for (const Eigen::Vector3d& v : {along, Eigen::Vector3d(Eigen::Vector3d::Zero())}) {
      if (v != starts.back().velocity || !starts.back().acceleration.isZero()) {
        starts.push_back({v, Eigen::Vector3d::Zero(), {}});
      }
    }
  }
  std::string error = "no start state tried";
  for (size_t attempt = 0; attempt < starts.size(); ++attempt) {
    const Eigen::Vector3d& v0 = starts[attempt].velocity;
    const Eigen::Vector3d& a0 = starts[attempt].acceleration;
    way2 = base_way;
    std::vector<double> caps = base_cap;
    leaving = base_leaving;
    // Rests at the run-out's points (if any), checked without leaving.
    const std::vector<Eigen::Vector2d>& run_out = starts[attempt].run_out;
    way2.insert(way2.begin() + 1, run_out.begin(), run_out.end());
    caps.insert(caps.begin() + 1, run_out.size(), 0.0);
    leaving.insert(leaving.begin(), run_out.size(), false);
    std::vector<bool> stop_at(way2.size(), false);  // knots where the vehicle rests
    std::fill_n(stop_at.begin() + 1, run_out.size(), true);
    plan.repair_rounds = 0;
    for (;;) {
      std::vector<Eigen::Vector3d> way3;
      for (size_t i = 0; i < way2.size(); ++i) {
        way3.emplace_back(way2[i].x(), way2[i].y(), i == 0 ? start.position_m.z() : height_m);
      }
      std::vector<double> speed_caps = caps;
      for (size_t i = 0; i < caps.size(); ++i) {
        if (stop_at[i]) speed_caps[i] = 0.0;
      }
      const Eigen::Vector3d first_leg = way3[1] - way3[0];
      const double start_speed =
          first_leg.norm() > 1e-9 ? std::max(0.0, v0.dot(first_leg.normalized())) : 0.0;
      // The profile's limits: max_speed and kProfileAcceleration max_acceleration at first, then
      // lowered by the sampled overshoot (up to kProfileRefinements times).
      TrajectoryConfig profile = config;
      profile.max_acceleration_mps2 *= kProfileAcceleration;
      int refinements = 0;
      std::vector<double> durations = ProfileDurations(way3, speed_caps, start_speed, profile);
      std::optional<PiecewisePolynomialTrajectory> traj;
      std::optional<std::vector<PolynomialSegment>> segs;
      // Stretching time lowers speed and acceleration as 1/T and 1/T^2 from rest, but not with a
      // start velocity (the piece overshoots by about v0 T): past this bound on the total
      // duration (and before sampling a huge trajectory) give up on this start state.
      std::string solve_error;
      double unscaled_total_s = 0.0;
      for (double t : durations) unscaled_total_s += t;
      const double max_total_s = 16.0 * unscaled_total_s + 60.0;
      for (int scaling = 0; scaling < 12 + kProfileRefinements; ++scaling) {
        traj.reset();
        double total = 0.0;
        for (double t : durations) total += t;
        if (total > max_total_s) break;  // not converging
        segs = SolveMinimumDerivative(way3, durations, k, v0, a0, stop_at);
        if (!segs) {
          solve_error = "KKT system could not be solved";
          break;  // the next start state
        }
        std::string reason;
        traj = PiecewisePolynomialTrajectory::Create(start.time_s, *segs, &reason);
        if (!traj) {
          solve_error = "invalid trajectory: " + reason;
          break;  // the next start state
        }
        double v_max_sampled = 0.0, a_max_sampled = 0.0;
        for (const TrajectorySample& s : traj->Sample(config.sample_period_s)) {
          v_max_sampled = std::max(v_max_sampled, s.flat.velocity_mps.norm());
          a_max_sampled = std::max(a_max_sampled, s.flat.acceleration_mps2.norm());
        }
        const double speed_ratio = v_max_sampled / v_max;
        const double acceleration_ratio = a_max_sampled / config.max_acceleration_mps2;
        const double factor = std::max(speed_ratio, std::sqrt(acceleration_ratio));
        if (factor <= 1.0) break;
        if (refinements < kProfileRefinements) {
          ++refinements;
          profile.max_speed_mps /= std::max(1.0, speed_ratio) * 1.005;
          profile.max_acceleration_mps2 /= std::max(1.0, acceleration_ratio) * 1.005;
          durations = ProfileDurations(way3, speed_caps, start_speed, profile);
          continue;
        }
        if (scaling + 1 == 12 + kProfileRefinements) traj.reset();  // did not converge
        for (double& t : durations) t *= factor * 1.01;             // v ~ 1/T, a ~ 1/T^2
      }
      if (!traj.has_value()) {
        error = !solve_error.empty()
                    ? solve_error
                    : "time allocation did not meet the speed and acceleration limits";
        break;  // the next start state
      }
      // Check the disc at every sample; collect the pieces that leave the allowed cells.
      std::vector<bool> bad(durations.size(), false);
      bool any_bad = false;
      for (const TrajectorySample& s : traj->Sample(config.sample_period_s)) {
        double t = s.time_s - start.time_s;
        size_t seg = 0;
        while (seg + 1 < durations.size() && t > durations[seg]) t -= durations[seg++];
        // In a passage, within its tolerance of its middle line only (PathClearance), unless the
        // piece is straight (a rest at both ends): then it is a segment SegmentClear checked.
        const bool straight = (seg == 0 ? v0.isZero() && a0.isZero() : stop_at[seg]) &&
                              (seg + 2 == way2.size() || stop_at[seg + 1]);
        if (DiscClear(collision, leaving[seg] ? allowed_leaving : allowed,
                      s.flat.position_m.head<2>(), r) &&
            (straight || WithinPassage(clearance, collision, s.flat.position_m.head<2>()))) {
          continue;
        }
        bad[seg] = true;
        any_bad = true;
      }
      if (!any_bad) {
        plan.stop_waypoints = static_cast<int>(std::count(stop_at.begin(), stop_at.end(), true));
        plan.start_matched = attempt == 0 || !run_out.empty();
        plan.trajectory = WithYaw(*segs, way3, start, goal_yaw_rad, config, &plan.waypoints,
                                  &plan.yaw_duration_s);
        if (!plan.trajectory) plan.error = "invalid trajectory after adding the yaw";
        return plan;
      }
      if (plan.repair_rounds < config.max_repair_rounds) {
        // Repair: the midpoint of a line-of-sight-checked straight segment is a safe waypoint.
        std::vector<Eigen::Vector2d> repaired{way2.front()};
        std::vector<bool> repaired_stop{stop_at.front()};
        std::vector<double> repaired_caps{caps.front()};
        std::vector<bool> repaired_leaving;
        for (size_t i = 0; i + 1 < way2.size(); ++i) {
          if (bad[i]) {
            repaired.push_back(0.5 * (way2[i] + way2[i + 1]));
            repaired_stop.push_back(false);
            repaired_caps.push_back(v_max);          // no turn there
            repaired_leaving.push_back(leaving[i]);  // both halves keep the piece's rule
          }
          repaired.push_back(way2[i + 1]);
          repaired_stop.push_back(stop_at[i + 1]);
          repaired_caps.push_back(caps[i + 1]);
          repaired_leaving.push_back(leaving[i]);
        }
        way2 = repaired;
        stop_at = repaired_stop;
        caps = repaired_caps;
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
        error = "sampled trajectory leaves the traversable cells even with rests at waypoints";
        break;  // the next start state
      }
    }
  }
  plan.error = error;
  return plan;
}

TrajectoryPlan PlanTrajectory(const GridMap2D& collision, const std::vector<bool>& traversable,
                              const DistanceField& field, int goal_cell,
                              const Eigen::Vector3d& start_position_m,
                              const Eigen::Vector3d& start_velocity_mps, double start_yaw_rad,
                              double goal_yaw_rad, double height_m, double start_time_s,
                              const TrajectoryConfig& config) {
  TrajectoryStart start;
  start.position_m = start_position_m;
  start.velocity_mps = start_velocity_mps;
  start.yaw_rad = start_yaw_rad;
  start.time_s = start_time_s;
  return PlanTrajectory(collision, traversable, field, goal_cell, start, goal_yaw_rad, height_m,
                        config);
}

}  // namespace kestrel

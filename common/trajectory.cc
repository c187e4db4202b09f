#include "common/trajectory.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "common/check.h"

namespace kestrel {

namespace {
constexpr const char* kAxisNames[4] = {"x", "y", "z", "yaw"};
}  // namespace

FlatOutput FlatOutput::Hover(const Eigen::Vector3d& position_m, double yaw_rad) {
  FlatOutput flat;
  flat.position_m = position_m;
  flat.yaw_rad = yaw_rad;
  return flat;
}

bool FlatOutput::IsFinite() const {
  return position_m.allFinite() && velocity_mps.allFinite() && acceleration_mps2.allFinite() &&
         jerk_mps3.allFinite() && snap_mps4.allFinite() && std::isfinite(yaw_rad) &&
         std::isfinite(yaw_rate_radps) && std::isfinite(yaw_acceleration_radps2);
}

void EvaluatePolynomial(const std::vector<double>& c, double tau, double out[5]) {
  const int n = static_cast<int>(c.size());
  for (int d = 0; d < 5; ++d) {
    // d-th derivative: sum_{k>=d} c[k] * k!/(k-d)! * tau^(k-d), by Horner from the top.
    double acc = 0.0;
    for (int k = n - 1; k >= d; --k) {
      double falling = 1.0;  // k (k-1) ... (k-d+1)
      for (int j = 0; j < d; ++j) falling *= static_cast<double>(k - j);
      acc = acc * tau + c[static_cast<size_t>(k)] * falling;
    }
    out[d] = acc;
  }
}

std::string PiecewisePolynomialTrajectory::CheckSegments(
    const std::vector<PolynomialSegment>& segments) {
  std::ostringstream error;
  if (segments.empty()) return "trajectory has no segments";
  double total_s = 0.0;
  for (size_t i = 0; i < segments.size(); ++i) {
    const PolynomialSegment& segment = segments[i];
    if (!std::isfinite(segment.duration_s) || !(segment.duration_s > 0.0)) {
      error << "segment " << i << ": duration_s = " << segment.duration_s
            << " must be finite and > 0";
      return error.str();
    }
    total_s += segment.duration_s;
    for (int axis = 0; axis < 4; ++axis) {
      const std::vector<double>& c = segment.coefficients[static_cast<size_t>(axis)];
      if (c.empty() || static_cast<int>(c.size()) > kMaxCoefficients) {
        error << "segment " << i << " axis " << kAxisNames[axis] << ": " << c.size()
              << " coefficients, accepted 1.." << kMaxCoefficients;
        return error.str();
      }
      for (size_t k = 0; k < c.size(); ++k) {
        if (!std::isfinite(c[k])) {
          error << "segment " << i << " axis " << kAxisNames[axis] << ": coefficient " << k << " = "
                << c[k] << " is not finite";
          return error.str();
        }
      }
    }
  }
  if (!std::isfinite(total_s)) return "total duration is not finite";
  return "";
}

std::optional<PiecewisePolynomialTrajectory> PiecewisePolynomialTrajectory::Create(
    double start_time_s, std::vector<PolynomialSegment> segments, std::string* error) {
  std::string reason = CheckSegments(segments);
  if (reason.empty() && !std::isfinite(start_time_s)) reason = "start time is not finite";
  if (!reason.empty()) {
    if (error != nullptr) *error = reason;
    return std::nullopt;
  }
  if (error != nullptr) error->clear();
  return PiecewisePolynomialTrajectory(start_time_s, std::move(segments));
}

std::optional<PiecewisePolynomialTrajectory> PiecewisePolynomialTrajectory::CreateFromFlat(
    double start_time_s, const std::vector<double>& durations_s, int num_coefficients,
    const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z,
    const std::vector<double>& yaw, std::string* error) {
  auto fail = [error](const std::string& reason) {
    if (error != nullptr) *error = reason;
    return std::nullopt;
  };
  if (num_coefficients < 1 || num_coefficients > kMaxCoefficients) {
    return fail("num_coefficients = " + std::to_string(num_coefficients) + ", accepted 1.." +
                std::to_string(kMaxCoefficients));
  }
  const size_t n = static_cast<size_t>(num_coefficients);
  const size_t expected = durations_s.size() * n;
  const std::vector<double>* axes[4] = {&x, &y, &z, &yaw};
  for (int axis = 0; axis < 4; ++axis) {
    if (axes[axis]->size() != expected) {
      return fail(std::string("axis ") + kAxisNames[axis] + " has " +
                  std::to_string(axes[axis]->size()) + " coefficients, expected " +
                  std::to_string(durations_s.size()) + " segments x " + std::to_string(n) + " = " +
                  std::to_string(expected));
    }
  }
  std::vector<PolynomialSegment> segments(durations_s.size());
  for (size_t i = 0; i < durations_s.size(); ++i) {
    segments[i].duration_s = durations_s[i];
    for (int axis = 0; axis < 4; ++axis) {
      const auto begin = axes[axis]->begin() + static_cast<std::ptrdiff_t>(i * n);
      segments[i].coefficients[static_cast<size_t>(axis)].assign(
          begin, begin + static_cast<std::ptrdiff_t>(n));
    }
  }
  return Create(start_time_s, std::move(segments), error);
}

PiecewisePolynomialTrajectory::PiecewisePolynomialTrajectory(
    double start_time_s, std::vector<PolynomialSegment> segments)
    : start_time_s_(start_time_s), segments_(std::move(segments)) {
  knots_s_.reserve(segments_.size() + 1);
  knots_s_.push_back(0.0);
  for (const PolynomialSegment& segment : segments_) {
    knots_s_.push_back(knots_s_.back() + segment.duration_s);
  }
}

FlatOutput PiecewisePolynomialTrajectory::EvaluateSegment(int i, double tau_s) const {
  const PolynomialSegment& segment = segments_[static_cast<size_t>(i)];
  FlatOutput flat;
  double d[5];
  for (int axis = 0; axis < 3; ++axis) {
    EvaluatePolynomial(segment.coefficients[static_cast<size_t>(axis)], tau_s, d);
    flat.position_m[axis] = d[0];
    flat.velocity_mps[axis] = d[1];
    flat.acceleration_mps2[axis] = d[2];
    flat.jerk_mps3[axis] = d[3];
    flat.snap_mps4[axis] = d[4];
  }
  EvaluatePolynomial(segment.coefficients[3], tau_s, d);
  flat.yaw_rad = d[0];
  flat.yaw_rate_radps = d[1];
  flat.yaw_acceleration_radps2 = d[2];
  return flat;
}

FlatTrajectory PiecewisePolynomialTrajectory::ToFlat() const {
  FlatTrajectory flat;
  flat.start_time_s = start_time_s_;
  for (const PolynomialSegment& segment : segments_) {
    flat.durations_s.push_back(segment.duration_s);
    for (const std::vector<double>& c : segment.coefficients) {
      flat.num_coefficients = std::max(flat.num_coefficients, static_cast<int>(c.size()));
    }
  }
  const size_t n = static_cast<size_t>(flat.num_coefficients);
  std::vector<double>* axes[4] = {&flat.x, &flat.y, &flat.z, &flat.yaw};
  for (int axis = 0; axis < 4; ++axis) {
    axes[axis]->assign(segments_.size() * n, 0.0);
    for (size_t i = 0; i < segments_.size(); ++i) {
      const std::vector<double>& c = segments_[i].coefficients[static_cast<size_t>(axis)];
      std::copy(c.begin(), c.end(), axes[axis]->begin() + static_cast<std::ptrdiff_t>(i * n));
    }
  }
  return flat;
}

FlatOutput PiecewisePolynomialTrajectory::Evaluate(double t_s) const {
  const double t_local = t_s - start_time_s_;
  if (!(t_local >= 0.0)) {  // before the start, or NaN: hover at the start
    const FlatOutput at_start = EvaluateSegment(0, 0.0);
    return FlatOutput::Hover(at_start.position_m, at_start.yaw_rad);
  }
  const int last = num_segments() - 1;
  if (t_local > knots_s_.back()) {  // after the end: hover at the end
    const FlatOutput at_end = EvaluateSegment(last, segments_.back().duration_s);
    return FlatOutput::Hover(at_end.position_m, at_end.yaw_rad);
  }
  // The segment i with knots_s_[i] <= t_local < knots_s_[i + 1]; the last one includes its end.
  const auto it = std::upper_bound(knots_s_.begin(), knots_s_.end(), t_local);
  int i = static_cast<int>(it - knots_s_.begin()) - 1;
  i = std::clamp(i, 0, last);
  const double tau_s = std::min(t_local - knots_s_[static_cast<size_t>(i)],
                                segments_[static_cast<size_t>(i)].duration_s);
  return EvaluateSegment(i, tau_s);
}

std::vector<TrajectorySample> PiecewisePolynomialTrajectory::Sample(double dt_s) const {
  KESTREL_THROW_UNLESS(std::isfinite(dt_s) && dt_s > 0.0,
                       "Sample: dt_s = " << dt_s << ", accepted (0, inf)");
  std::vector<TrajectorySample> samples;
  const double duration = duration_s();
  const auto n = static_cast<size_t>(std::floor(duration / dt_s));
  samples.reserve(n + 2);
  for (size_t k = 0; k <= n; ++k) {
    const double t_local = static_cast<double>(k) * dt_s;
    if (t_local >= duration) break;
    samples.push_back({start_time_s_ + t_local, Evaluate(start_time_s_ + t_local)});
  }
  samples.push_back({end_time_s(), Evaluate(end_time_s())});
  return samples;
}

std::vector<double> TaylorShift(const std::vector<double>& c, double shift) {
  // Repeated synthetic division (Horner's scheme, one pass per coefficient): O(n^2), exact for
  // shift 0.
  std::vector<double> d = c;
  const int n = static_cast<int>(d.size());
  for (int i = 0; i < n - 1; ++i) {
    for (int k = n - 2; k >= i; --k) {
      d[static_cast<size_t>(k)] += shift * d[static_cast<size_t>(k) + 1];
    }
  }
  return d;
}

TrajectoryStart StateAt(const PiecewisePolynomialTrajectory& trajectory, double t_s) {
  const FlatOutput flat = trajectory.Evaluate(t_s);
  TrajectoryStart start;
  start.position_m = flat.position_m;
  start.velocity_mps = flat.velocity_mps;
  start.acceleration_mps2 = flat.acceleration_mps2;
  start.yaw_rad = flat.yaw_rad;
  start.yaw_rate_radps = flat.yaw_rate_radps;
  start.time_s = t_s;
  return start;
}

std::optional<PiecewisePolynomialTrajectory> Splice(const PiecewisePolynomialTrajectory& old,
                                                    double now_s,
                                                    const PiecewisePolynomialTrajectory& next) {
  const double splice_s = next.start_time_s();
  if (!std::isfinite(now_s) || splice_s < now_s) return std::nullopt;
  std::vector<PolynomialSegment> pieces;
  // A constant piece (the clamped hover of `old` before its start or after its end).
  const auto hover = [&pieces](const FlatOutput& at, double duration_s) {
    PolynomialSegment piece;
    piece.duration_s = duration_s;
    for (int axis = 0; axis < 3; ++axis) {
      piece.coefficients[static_cast<size_t>(axis)] = {at.position_m[axis]};
    }
    piece.coefficients[3] = {at.yaw_rad};
    pieces.push_back(std::move(piece));
  };
  if (now_s < std::min(old.start_time_s(), splice_s)) {
    hover(old.Evaluate(old.start_time_s()), std::min(old.start_time_s(), splice_s) - now_s);
  }
  double piece_start_s = old.start_time_s();
  for (const PolynomialSegment& segment : old.segments()) {
    const double piece_end_s = piece_start_s + segment.duration_s;
    const double from_s = std::max(piece_start_s, now_s);
    const double to_s = std::min(piece_end_s, splice_s);
    if (to_s > from_s) {
      PolynomialSegment piece;
      piece.duration_s = to_s - from_s;
      for (size_t axis = 0; axis < 4; ++axis) {
        piece.coefficients[axis] = TaylorShift(segment.coefficients[axis], from_s - piece_start_s);
      }
      pieces.push_back(std::move(piece));
    }
    piece_start_s = piece_end_s;
  }
  if (splice_s > std::max(old.end_time_s(), now_s)) {
    const FlatOutput at_end = old.Evaluate(old.end_time_s() + 1.0);  // the end hover
    hover(at_end, splice_s - std::max(old.end_time_s(), now_s));
  }
  for (const PolynomialSegment& segment : next.segments()) pieces.push_back(segment);
  return PiecewisePolynomialTrajectory::Create(now_s, std::move(pieces), nullptr);
}

std::optional<PiecewisePolynomialTrajectory> RestToRest(double start_time_s,
                                                        const Eigen::Vector3d& from_m,
                                                        const Eigen::Vector3d& to_m, double yaw_rad,
                                                        double duration_s, std::string* error) {
  if (!from_m.allFinite() || !to_m.allFinite() || !std::isfinite(yaw_rad) || !(duration_s > 0.0) ||
      !std::isfinite(duration_s)) {
    if (error != nullptr) *error = "rest-to-rest move: non-finite point or yaw, or duration <= 0";
    return std::nullopt;
  }
  PolynomialSegment segment;
  segment.duration_s = duration_s;
  const double t4 = std::pow(duration_s, 4);
  for (int axis = 0; axis < 3; ++axis) {
    const double d = to_m[axis] - from_m[axis];
    segment.coefficients[axis] = {from_m[axis],
                                  0.0,
                                  0.0,
                                  0.0,
                                  35.0 * d / t4,
                                  -84.0 * d / (t4 * duration_s),
                                  70.0 * d / (t4 * duration_s * duration_s),
                                  -20.0 * d / (t4 * duration_s * duration_s * duration_s)};
  }
  segment.coefficients[3] = {yaw_rad};
  return PiecewisePolynomialTrajectory::Create(start_time_s, {segment}, error);
}

}  // namespace kestrel

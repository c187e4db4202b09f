#include "tools/fidelity/mount_calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "common/check.h"

namespace kestrel {

namespace {

constexpr int kN = kMountParameters;
using Vector7 = Eigen::Matrix<double, kN, 1>;
using Matrix7 = Eigen::Matrix<double, kN, kN>;

constexpr double kBandM = 0.5;       // residual scale bands by measured range, m
constexpr int kMinBandReturns = 30;  // a band with fewer uses the scale of all returns
constexpr double kMinScaleM = 5e-4;  // scale floor, m
// The pose track's time derivative: a central difference over +-25 ms, several motion-capture
// samples, so that it holds the vehicle's motion and not the samples' noise (at hover the
// difference of two noisy samples 10 ms apart looks like a turn of a few tenths of a rad/s).
constexpr double kTimeStepS = 0.025;
constexpr double kNeighbourM = 0.003;  // lateral offset of the neighbouring casts at the hit, m
constexpr double kCastMarginM = 0.5;   // casts reach this far beyond z_max, m
constexpr double kStepTranslationM = 1e-5;  // converged: every step below these
constexpr double kStepRotationRad = 1e-5;
constexpr double kStepOffsetS = 1e-5;
constexpr double kStepStandardErrors = 0.05;   // or: a step this short in standard errors
constexpr double kMaxStepTranslationM = 0.01;  // trust region of one step
constexpr double kMaxStepRotationRad = 0.02;
constexpr double kMaxStepOffsetS = 0.02;

// J_r(w): Exp(w + dw) = Exp(w) Exp(J_r(w) dw) to first order in dw.
Eigen::Matrix3d RightJacobian(const Eigen::Vector3d& w) {
  const double t = w.norm();
  const Eigen::Matrix3d W = Hat(w);
  if (t < 1e-8) return Eigen::Matrix3d::Identity() - 0.5 * W;
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(t)) / (t * t) * W +
         (t - std::sin(t)) / (t * t * t) * W * W;
}

// 1.4826 median |r|: the standard deviation of Gaussian residuals, robustly. Reorders *r.
double RobustScale(std::vector<double>* r) {
  if (r->empty()) return 0.0;
  const auto mid = r->begin() + static_cast<std::ptrdiff_t>(r->size() / 2);
  std::nth_element(r->begin(), mid, r->end());
  return 1.4826 * *mid;
}

double Limit(const MountCalibrationOptions& o, int k) {
  return k < 3   ? o.determined_translation_m
         : k < 6 ? o.determined_rotation_rad
                 : o.determined_offset_s;
}

}  // namespace

Pose3 MountCorrection::Transform() const {
  return Pose3{translation_m, QuaternionFromRotationVector(rotation_rad)};
}

const char* MountParameterName(int k) {
  static const char* const kNames[kN] = {"translation x", "translation y", "translation z",
                                         "rotation x",    "rotation y",    "rotation z",
                                         "stamp offset"};
  return k >= 0 && k < kN ? kNames[k] : "?";
}

std::string FormatMountParameter(int k, double value) {
  char text[64];
  if (k < 3) {
    std::snprintf(text, sizeof text, "%.2f mm", 1e3 * value);
  } else if (k < 6) {
    std::snprintf(text, sizeof text, "%.3f deg", value * 180.0 / M_PI);
  } else {
    std::snprintf(text, sizeof text, "%.2f ms", 1e3 * value);
  }
  return text;
}

void MountCalibrationOptions::Validate() const {
  KESTREL_THROW_UNLESS(rays_per_scan >= 1,
                       "rays_per_scan = " << rays_per_scan << ", accepted >= 1");
  KESTREL_THROW_UNLESS(min_returns >= 1, "min_returns = " << min_returns << ", accepted >= 1");
  KESTREL_THROW_UNLESS(max_iterations >= 1,
                       "max_iterations = " << max_iterations << ", accepted >= 1");
  KESTREL_THROW_UNLESS(huber_k > 0 && gate_sigmas > huber_k && start_gate_m > 0,
                       "huber_k = " << huber_k << ", gate_sigmas = " << gate_sigmas
                                    << ", start_gate_m = " << start_gate_m
                                    << ", accepted 0 < huber_k < gate_sigmas, start_gate_m > 0");
  KESTREL_THROW_UNLESS(min_incidence_cosine > 0 && min_incidence_cosine < 1,
                       "min_incidence_cosine = " << min_incidence_cosine << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(
      determined_translation_m > 0 && determined_rotation_rad > 0 && determined_offset_s > 0,
      "the determined_* limits must be positive");
  KESTREL_THROW_UNLESS(max_translation_m > 0 && max_rotation_rad > 0 && max_offset_s > 0,
                       "the max_* limits must be positive");
  KESTREL_THROW_UNLESS(min_inlier_fraction >= 0 && min_inlier_fraction <= 1,
                       "min_inlier_fraction = " << min_inlier_fraction << ", accepted [0, 1]");
}

MountCalibrator::MountCalibrator(const WorldRayCaster& caster, const Pose3& X_BS, double z_min_m,
                                 double z_max_m, const PoseHistoryConfig& pairing,
                                 const MountCalibrationOptions& options)
    : caster_(caster),
      X_BS_(X_BS),
      z_min_(z_min_m),
      z_max_(z_max_m),
      options_(options),
      // Every pose of the run is kept; the gap rule is the mapper's.
      poses_(PoseHistoryConfig{1e9, pairing.max_gap_s, pairing.max_wait_s}) {
  KESTREL_THROW_UNLESS(z_min_m >= 0 && z_max_m > z_min_m && std::isfinite(z_max_m),
                       "MountCalibrator: z_min_m = " << z_min_m << ", z_max_m = " << z_max_m
                                                     << ", accepted 0 <= z_min < z_max, finite");
  options_.Validate();
}

void MountCalibrator::AddPose(int64_t utime, const Pose3& X_WB) { (void)poses_.Add(utime, X_WB); }

void MountCalibrator::AddScan(int64_t stamp_us, const std::vector<SensorRay>& rays_S) {
  std::vector<size_t> returns;
  for (size_t i = 0; i < rays_S.size(); ++i) {
    const Reading& r = rays_S[i].reading;
    if (r.kind == ReadingKind::kReturn && r.z_m >= z_min_ && r.z_m < z_max_) returns.push_back(i);
  }
  const auto scan = static_cast<int32_t>(scans_.size());
  scans_.push_back(stamp_us);
  const size_t n = returns.size();
  const auto keep = static_cast<size_t>(options_.rays_per_scan);
  // Evenly spread, the start moving by the golden ratio's fraction from scan to scan.
  const double phase = std::fmod(0.6180339887498949 * scan, 1.0);
  for (size_t k = 0; k < std::min(n, keep); ++k) {
    const size_t i = n <= keep
                         ? k
                         : std::min(n - 1, static_cast<size_t>((static_cast<double>(k) + phase) *
                                                               static_cast<double>(n) /
                                                               static_cast<double>(keep)));
    const SensorRay& ray = rays_S[returns[i]];
    rays_.push_back(Ray{ray.origin_W, ray.direction_W, ray.reading.z_m, scan});
  }
}

struct MountCalibrator::Linearisation {
  std::vector<double> r;   // z - d; NaN where the ray is not usable at theta
  std::vector<Vector7> J;  // d r / d theta
};

void MountCalibrator::Linearise(const MountCorrection& theta, Linearisation* out) const {
  const size_t n = rays_.size();
  out->r.assign(n, std::numeric_limits<double>::quiet_NaN());
  out->J.assign(n, Vector7::Zero());
  const Eigen::Matrix3d R_C = QuaternionFromRotationVector(theta.rotation_rad).toRotationMatrix();
  const Eigen::Matrix3d Jr = RightJacobian(theta.rotation_rad);
  const double cast_max = z_max_ + kCastMarginM;
  const auto h_us = static_cast<int64_t>(std::llround(kTimeStepS * 1e6));
  struct SensorPose {
    Eigen::Matrix3d R_WS0, R_WS;  // without and with the correction's rotation
    Eigen::Vector3d p_WS;         // with the correction's translation
  };
  // The sensor's pose at pose-clock time t_us (false: no pose pairs there).
  const auto sensor_pose = [&](int64_t t_us, SensorPose* s) {
    Pose3 X_WB;
    if (poses_.Lookup(t_us, t_us, &X_WB) != PoseLookupResult::kOk) return false;
    const Pose3 X_WS0 = X_WB * X_BS_;
    s->R_WS0 = X_WS0.q.normalized().toRotationMatrix();
    s->R_WS = s->R_WS0 * R_C;
    s->p_WS = X_WS0.p + s->R_WS0 * theta.translation_m;
    return true;
  };
  size_t begin = 0;
  while (begin < n) {
    const int32_t scan = rays_[begin].scan;
    size_t end = begin;
    while (end < n && rays_[end].scan == scan) ++end;
    const auto t_us = static_cast<int64_t>(std::llround(
        static_cast<double>(scans_[static_cast<size_t>(scan)]) - 1e6 * theta.stamp_offset_s));
    SensorPose at, later, earlier;
    if (!sensor_pose(t_us, &at) || !sensor_pose(t_us + h_us, &later) ||
        !sensor_pose(t_us - h_us, &earlier)) {
      begin = end;
      continue;
    }
    const double h_s = 1e-6 * static_cast<double>(h_us);
    for (size_t i = begin; i < end; ++i) {
      const Ray& ray = rays_[i];
      const Eigen::Vector3d o = at.p_WS + at.R_WS * ray.origin_S;
      const Eigen::Vector3d u = at.R_WS * ray.direction_S;
      int primitive = WorldRayCaster::kNoHit;
      const double d = caster_.CastRay(o, u, cast_max, &primitive);
      if (!std::isfinite(d) || d <= 0.0) continue;
      // The surface's plane at the hit, from two neighbouring casts on the same primitive (a ray
      // at an edge between primitives has no derivative: left out at this theta).
      const Eigen::Vector3d e1 = u.unitOrthogonal();
      const Eigen::Vector3d e2 = u.cross(e1);
      const double eps = kNeighbourM / d;
      const Eigen::Vector3d u1 = (u + eps * e1).normalized();
      const Eigen::Vector3d u2 = (u + eps * e2).normalized();
      int primitive1 = WorldRayCaster::kNoHit, primitive2 = WorldRayCaster::kNoHit;
      const double d1 = caster_.CastRay(o, u1, cast_max, &primitive1, primitive);
      const double d2 = caster_.CastRay(o, u2, cast_max, &primitive2, primitive);
      if (primitive1 != primitive || primitive2 != primitive || !std::isfinite(d1) ||
          !std::isfinite(d2)) {
        continue;
      }
      const Eigen::Vector3d hit = o + d * u;
      Eigen::Vector3d normal = (o + d1 * u1 - hit).cross(o + d2 * u2 - hit);
      if (!(normal.norm() > 0.0)) continue;
      normal.normalize();
      const double cosine = normal.dot(u);
      if (!(std::abs(cosine) >= options_.min_incidence_cosine)) continue;
      // d(o, u) = n . (x0 - o) / (n . u) on the plane through x0.
      const Eigen::Vector3d dd_do = -normal / cosine;
      const Eigen::Vector3d dd_du = -d * normal / cosine;
      Vector7 dd;
      dd.segment<3>(0) = at.R_WS0.transpose() * dd_do;
      const Eigen::Matrix3d do_dw = -at.R_WS * Hat(ray.origin_S) * Jr;
      const Eigen::Matrix3d du_dw = -at.R_WS * Hat(ray.direction_S) * Jr;
      dd.segment<3>(3) = do_dw.transpose() * dd_do + du_dw.transpose() * dd_du;
      // The pose is read at t - delta: d/d delta = -d/dt.
      const Eigen::Vector3d do_ddelta = -((later.p_WS + later.R_WS * ray.origin_S) -
                                          (earlier.p_WS + earlier.R_WS * ray.origin_S)) /
                                        (2.0 * h_s);
      const Eigen::Vector3d du_ddelta =
          -(later.R_WS * ray.direction_S - earlier.R_WS * ray.direction_S) / (2.0 * h_s);
      dd[6] = dd_do.dot(do_ddelta) + dd_du.dot(du_ddelta);
      out->r[i] = ray.z_m - d;
      out->J[i] = -dd;
    }
    begin = end;
  }
}

namespace {

// Robust scales per range band from the usable residuals within the gate of `previous` (empty:
// within start_gate_m), and the weights of every ray under them (0: not usable or beyond the
// gate). Returns the scale of all the gated residuals.
double Weigh(const std::vector<double>& r, const std::vector<double>& z,
             const MountCalibrationOptions& o, double z_max, std::vector<double>* scales,
             std::vector<double>* w) {
  const auto bands = static_cast<size_t>(std::ceil((z_max + kCastMarginM) / kBandM));
  const auto band_of = [&](double z_m) {
    return std::min(bands - 1, static_cast<size_t>(std::max(0.0, z_m / kBandM)));
  };
  const std::vector<double> previous = *scales;
  const auto gate = [&](size_t i) {
    return previous.empty() ? o.start_gate_m : o.gate_sigmas * previous[band_of(z[i])];
  };
  std::vector<std::vector<double>> in_band(bands);
  std::vector<double> all;
  for (size_t i = 0; i < r.size(); ++i) {
    if (!std::isfinite(r[i]) || !(std::abs(r[i]) <= gate(i))) continue;
    in_band[band_of(z[i])].push_back(std::abs(r[i]));
    all.push_back(std::abs(r[i]));
  }
  const double scale_all = std::max(kMinScaleM, RobustScale(&all));
  scales->assign(bands, scale_all);
  for (size_t b = 0; b < bands; ++b) {
    if (in_band[b].size() >= static_cast<size_t>(kMinBandReturns)) {
      (*scales)[b] = std::max(kMinScaleM, RobustScale(&in_band[b]));
    }
  }
  w->assign(r.size(), 0.0);
  for (size_t i = 0; i < r.size(); ++i) {
    if (!std::isfinite(r[i])) continue;
    const double s = (*scales)[band_of(z[i])];
    const double a = std::abs(r[i]) / s;
    if (a > o.gate_sigmas) continue;
    (*w)[i] = (a <= o.huber_k ? 1.0 : o.huber_k / a) / (s * s);
  }
  return scale_all;
}

}  // namespace

MountFit MountCalibrator::Fit(const MountCorrection& start,
                              const std::array<bool, kMountParameters>& required) const {
  MountFit fit;
  fit.scans = scans();
  fit.returns = returns();
  char text[256];
  if (fit.returns < options_.min_returns) {
    std::snprintf(text, sizeof text,
                  "too few returns: %lld in range from %lld scans, at least %d needed",
                  static_cast<long long>(fit.returns), static_cast<long long>(fit.scans),
                  options_.min_returns);
    fit.why = text;
    return fit;
  }
  std::vector<double> z(rays_.size());
  for (size_t i = 0; i < rays_.size(); ++i) z[i] = rays_[i].z_m;
  // A weak prior about the start keeps the axes the returns do not see determined (its sigma is
  // the plausible correction: it moves a determined axis by a negligible amount).
  Vector7 prior;
  for (int k = 0; k < kN; ++k) {
    const double sigma = k < 3   ? options_.max_translation_m
                         : k < 6 ? options_.max_rotation_rad
                                 : options_.max_offset_s;
    prior[k] = 1.0 / (sigma * sigma);
  }
  std::array<bool, kN> free{};
  free.fill(true);
  MountCorrection theta = start;
  Linearisation lin;
  std::vector<double> scales, w;
  Matrix7 A = Matrix7::Zero();
  Vector7 g = Vector7::Zero();
  std::vector<int> index;
  // The normal equations at theta over the free axes (A, g), with the weights of `scales`.
  const auto normal_equations = [&]() {
    Linearise(theta, &lin);
    const double scale = Weigh(lin.r, z, options_, z_max_, &scales, &w);
    if (fit.scale_start_m == 0.0) fit.scale_start_m = scale;
    fit.scale_end_m = scale;
    Matrix7 H = Matrix7::Zero();
    Vector7 b = Vector7::Zero();
    fit.returns_used = 0;
    for (size_t i = 0; i < rays_.size(); ++i) {
      if (w[i] <= 0.0) continue;
      ++fit.returns_used;
      H.noalias() += w[i] * lin.J[i] * lin.J[i].transpose();
      b.noalias() += w[i] * lin.r[i] * lin.J[i];
    }
    index.clear();
    for (int k = 0; k < kN; ++k) {
      if (free[static_cast<size_t>(k)]) index.push_back(k);
    }
    const auto m = static_cast<int>(index.size());
    A = Matrix7::Zero();
    g = Vector7::Zero();
    for (int a = 0; a < m; ++a) {
      for (int c = 0; c < m; ++c) A(a, c) = H(index[a], index[c]);
      A(a, a) += prior[index[a]];
      g[a] = b[index[a]] + prior[index[a]] * (theta[index[a]] - start[index[a]]);
    }
  };
  const auto implausible = [&]() {
    const double translation = theta.translation_m.cwiseAbs().maxCoeff();
    const double rotation = theta.rotation_rad.norm();
    if (translation <= options_.max_translation_m && rotation <= options_.max_rotation_rad &&
        std::abs(theta.stamp_offset_s) <= options_.max_offset_s) {
      return false;
    }
    std::snprintf(text, sizeof text,
                  "implausible correction: translation %.1f mm, rotation %.2f deg, stamp offset "
                  "%.1f ms (at most %.1f mm, %.2f deg, %.1f ms): the log, the world and the "
                  "configured mount do not belong together",
                  1e3 * translation, rotation * 180.0 / M_PI, 1e3 * theta.stamp_offset_s,
                  1e3 * options_.max_translation_m, options_.max_rotation_rad * 180.0 / M_PI,
                  1e3 * options_.max_offset_s);
    fit.why = text;
    return true;
  };
  // Pass 0 fits every axis; the axes the returns do not determine (and need not) are then held at
  // their start, and the next pass fits the others (held axes only grow: at most kN passes).
  for (int pass = 0; pass <= kN; ++pass) {
    bool converged = false;
    Vector7 step = Vector7::Zero();
    double step_in_standard_errors = 0.0;
    for (int it = 0; it < options_.max_iterations && !converged; ++it) {
      ++fit.iterations;
      normal_equations();
      const auto m = static_cast<int>(index.size());
      if (m == 0) break;
      const Eigen::VectorXd delta = -A.topLeftCorner(m, m).ldlt().solve(g.head(m));
      // Trust region: the whole step scaled down to the largest allowed on every axis.
      double shrink = 1.0;
      for (int a = 0; a < m; ++a) {
        const int k = index[a];
        const double most = k < 3   ? kMaxStepTranslationM
                            : k < 6 ? kMaxStepRotationRad
                                    : kMaxStepOffsetS;
        shrink = std::min(shrink, most / std::max(std::abs(delta[a]), 1e-300));
      }
      step.setZero();
      bool small = true;
      for (int a = 0; a < m; ++a) {
        const int k = index[a];
        step[k] = shrink * delta[a];
        theta[k] += step[k];
        const double tolerance = k < 3   ? kStepTranslationM
                                 : k < 6 ? kStepRotationRad
                                         : kStepOffsetS;
        if (!(std::abs(step[k]) < tolerance)) small = false;
      }
      // Or a step far inside the fit's own uncertainty: delta^T A delta is its squared length in
      // standard errors (A^-1 the covariance). An axis seen only to second order (a planar
      // LIDAR's tilt) otherwise rocks by more than the absolute tolerance from step to step.
      step_in_standard_errors = std::sqrt(std::max(0.0, delta.dot(A.topLeftCorner(m, m) * delta)));
      converged = small || (shrink == 1.0 && step_in_standard_errors < kStepStandardErrors);
    }
    if (converged && implausible()) return fit;
    // Standard errors where the fit ended: the model's (A^-1) and the sandwich clustered by scan
    // (the returns of one scan share its pose error and stamp jitter); the larger of the two. A
    // fit that wanders (no convergence) usually does so along an axis they show undetermined.
    normal_equations();
    const auto m = static_cast<int>(index.size());
    const Eigen::MatrixXd A_inv = A.topLeftCorner(m, m).inverse();
    std::vector<Eigen::VectorXd> per_scan(scans_.size(), Eigen::VectorXd::Zero(m));
    for (size_t i = 0; i < rays_.size(); ++i) {
      if (w[i] <= 0.0) continue;
      for (int a = 0; a < m; ++a) {
        per_scan[static_cast<size_t>(rays_[i].scan)][a] += w[i] * lin.r[i] * lin.J[i][index[a]];
      }
    }
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(m, m);
    for (const Eigen::VectorXd& s : per_scan) meat.noalias() += s * s.transpose();
    const Eigen::MatrixXd sandwich = A_inv * meat * A_inv;
    fit.standard_error = MountCorrection{};
    for (int a = 0; a < m; ++a) {
      fit.standard_error[index[a]] = std::sqrt(std::max(A_inv(a, a), sandwich(a, a)));
    }
    if (pass == 0) fit.free_standard_error = fit.standard_error;
    std::string missing;
    bool held_now = false;
    for (int a = 0; a < m; ++a) {
      const int k = index[a];
      if (fit.standard_error[k] <= Limit(options_, k)) continue;
      if (required[static_cast<size_t>(k)]) {
        missing += std::string(missing.empty() ? "" : ", ") + MountParameterName(k) +
                   " (standard error " + FormatMountParameter(k, fit.standard_error[k]) +
                   ", at most " + FormatMountParameter(k, Limit(options_, k)) + ")";
      } else {
        fit.held[static_cast<size_t>(k)] = true;
        free[static_cast<size_t>(k)] = false;
        theta[k] = start[k];
        fit.standard_error[k] = 0.0;
        held_now = true;
      }
    }
    if (!missing.empty()) {
      fit.why = "degenerate geometry: the returns do not determine " + missing +
                (missing.find("stamp offset") != std::string::npos
                     ? "; the stamp offset needs a flight that moves and turns"
                     : "; a flight past surfaces that face several ways would");
      return fit;
    }
    if (held_now) continue;
    if (!converged) {
      std::string last;
      for (int k = 0; k < kN; ++k) {
        if (step[k] != 0.0)
          last += std::string(last.empty() ? "" : ", ") + MountParameterName(k) + " " +
                  FormatMountParameter(k, step[k]);
      }
      std::snprintf(text, sizeof text, "%.2f", step_in_standard_errors);
      fit.why = "the fit did not converge in " + std::to_string(options_.max_iterations) +
                " Gauss-Newton steps (last step: " + last + ", " + text + " standard errors)";
      return fit;
    }
    break;
  }
  const double used = static_cast<double>(fit.returns_used) / static_cast<double>(fit.returns);
  if (used < options_.min_inlier_fraction) {
    std::snprintf(text, sizeof text,
                  "only %.0f%% of the returns lie within %.1f scales of the world's surfaces (at "
                  "least %.0f%% needed): is this the run's world?",
                  100.0 * used, options_.gate_sigmas, 100.0 * options_.min_inlier_fraction);
    fit.why = text;
    return fit;
  }
  fit.value = theta;
  fit.ok = true;
  return fit;
}

}  // namespace kestrel

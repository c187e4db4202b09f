#include "control/state_estimator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/check.h"

namespace kestrel {

namespace {

// Exp: rotation vector (rad) to unit quaternion.
Eigen::Quaterniond ExpRotation(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-12) {
    return Eigen::Quaterniond(1.0, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z()).normalized();
  }
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
}

// Log: unit quaternion to rotation vector (rad), shortest arc.
Eigen::Vector3d LogRotation(Eigen::Quaterniond q) {
  if (q.w() < 0.0) q.coeffs() *= -1.0;
  const double s = q.vec().norm();
  if (s < 1e-12) return 2.0 * q.vec();
  return 2.0 * std::atan2(s, q.w()) * q.vec() / s;
}

bool CheckPositive(double value) { return std::isfinite(value) && value > 0.0; }

}  // namespace

void StateEstimatorConfig::Validate() const {
  KESTREL_THROW_UNLESS(
      CheckPositive(position_bandwidth_radps),
      "estimator.position_bandwidth_radps = " << position_bandwidth_radps << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      CheckPositive(attitude_gain_per_s),
      "estimator.attitude_gain_per_s = " << attitude_gain_per_s << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(gyro_bias_gain_per_s2) && gyro_bias_gain_per_s2 >= 0.0,
      "estimator.gyro_bias_gain_per_s2 = " << gyro_bias_gain_per_s2 << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(max_gyro_bias_radps) && max_gyro_bias_radps >= 0.0,
      "estimator.max_gyro_bias_radps = " << max_gyro_bias_radps << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(CheckPositive(history_s) && history_s <= 10.0,
                       "estimator.history_s = " << history_s << ", accepted (0, 10]");
  KESTREL_THROW_UNLESS(
      CheckPositive(min_correction_dt_s),
      "estimator.min_correction_dt_s = " << min_correction_dt_s << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(
      std::isfinite(max_correction_dt_s) && max_correction_dt_s >= min_correction_dt_s,
      "estimator.max_correction_dt_s = "
          << max_correction_dt_s << ", accepted [min_correction_dt_s = " << min_correction_dt_s
          << ", inf)");
  // The discrete position correction must not overshoot: k_p dt_m = 2 w_p dt_m <= 1.
  KESTREL_THROW_UNLESS(2.0 * position_bandwidth_radps * max_correction_dt_s <= 1.0,
                       "estimator.position_bandwidth_radps = "
                           << position_bandwidth_radps << " with max_correction_dt_s = "
                           << max_correction_dt_s << ": accepted 2 w_p dt <= 1");
  KESTREL_THROW_UNLESS(
      CheckPositive(reset_innovation_m),
      "estimator.reset_innovation_m = " << reset_innovation_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(CheckPositive(gravity_mps2),
                       "estimator.gravity_mps2 = " << gravity_mps2 << ", accepted (0, inf)");
}

StateEstimator::StateEstimator(const StateEstimatorConfig& config)
    : config_(config),
      last_pose_time_s_(-std::numeric_limits<double>::infinity()),
      last_correction_time_s_(-std::numeric_limits<double>::infinity()) {
  config_.Validate();
}

StateEstimator::Node StateEstimator::Propagate(const Node& from, double t_s, bool has_imu,
                                               const ImuSample& imu) const {
  Node node = from;
  node.time_s = t_s;
  node.has_imu = has_imu;
  node.imu = imu;
  const double dt = t_s - from.time_s;
  if (dt <= 0.0) return node;
  if (has_imu) {
    const Eigen::Vector3d omega = imu.angular_velocity_radps - from.gyro_bias;
    // Attitude at mid-interval rotates the specific force (second order in dt).
    const Eigen::Quaterniond q_mid = (from.q_WB * ExpRotation(0.5 * dt * omega)).normalized();
    const Eigen::Vector3d a =
        q_mid * imu.specific_force_mps2 - config_.gravity_mps2 * Eigen::Vector3d::UnitZ();
    node.q_WB = (from.q_WB * ExpRotation(dt * omega)).normalized();
    node.position_m = from.position_m + from.velocity_mps * dt + 0.5 * a * dt * dt;
    node.velocity_mps = from.velocity_mps + a * dt;
  } else {
    node.position_m = from.position_m + from.velocity_mps * dt;
  }
  return node;
}

void StateEstimator::Correct(const PoseMeasurement& pose, double dt_m_s, Node* node) {
  const Eigen::Vector3d e_p = pose.position_m - node->position_m;
  if (e_p.norm() > config_.reset_innovation_m) {
    node->position_m = pose.position_m;
    node->q_WB = pose.q_WB;
    ++resets_;
    return;
  }
  const double w = config_.position_bandwidth_radps;
  node->position_m += std::min(1.0, 2.0 * w * dt_m_s) * e_p;
  node->velocity_mps += w * w * dt_m_s * e_p;
  const Eigen::Vector3d e_theta = LogRotation(node->q_WB.conjugate() * pose.q_WB);
  node->q_WB =
      (node->q_WB * ExpRotation(std::min(1.0, config_.attitude_gain_per_s * dt_m_s) * e_theta))
          .normalized();
  const double b_max = config_.max_gyro_bias_radps;
  node->gyro_bias = (node->gyro_bias - config_.gyro_bias_gain_per_s2 * dt_m_s * e_theta)
                        .cwiseMax(-b_max)
                        .cwiseMin(b_max);
}

bool StateEstimator::AddImu(const ImuSample& sample) {
  if (!std::isfinite(sample.time_s) || !sample.angular_velocity_radps.allFinite() ||
      !sample.specific_force_mps2.allFinite()) {
    ++rejected_inputs_;
    return false;
  }
  if (!initialized()) return false;
  if (!(sample.time_s > history_.back().time_s)) {
    ++rejected_inputs_;
    return false;
  }
  history_.push_back(Propagate(history_.back(), sample.time_s, true, sample));
  Trim();
  return true;
}

bool StateEstimator::AddPose(const PoseMeasurement& pose) {
  if (!std::isfinite(pose.time_s) || !pose.position_m.allFinite() ||
      !pose.q_WB.coeffs().allFinite() || std::abs(pose.q_WB.norm() - 1.0) > 1e-3) {
    ++rejected_inputs_;
    return false;
  }
  PoseMeasurement measured = pose;
  measured.q_WB.normalize();
  if (!initialized()) {
    Node node;
    node.time_s = measured.time_s;
    node.position_m = measured.position_m;
    node.q_WB = measured.q_WB;
    history_.push_back(node);
    last_pose_time_s_ = measured.time_s;
    last_correction_time_s_ = measured.time_s;
    return true;
  }
  if (measured.time_s < history_.front().time_s) {  // older than the history
    ++rejected_inputs_;
    return false;
  }
  const double dt_m = std::clamp(measured.time_s - last_correction_time_s_,
                                 config_.min_correction_dt_s, config_.max_correction_dt_s);
  // The last node at or before the stamp.
  size_t k = history_.size() - 1;
  while (history_[k].time_s > measured.time_s) --k;
  if (k + 1 == history_.size()) {
    // Newer than every IMU sample: extrapolate with the latest sample held.
    const Node& last = history_.back();
    Node node = Propagate(last, measured.time_s, last.has_imu, last.imu);
    Correct(measured, dt_m, &node);
    history_.push_back(node);
  } else {
    // Within the history: the interval (t_k, t_(k+1)] is propagated by sample k+1.
    const Node& next = history_[k + 1];
    Node node = Propagate(history_[k], measured.time_s, next.has_imu, next.imu);
    Correct(measured, dt_m, &node);
    size_t first_replay = k + 1;
    if (history_[k].time_s == measured.time_s) {
      history_[k] = node;
    } else {
      history_.insert(history_.begin() + static_cast<std::ptrdiff_t>(k + 1), node);
      first_replay = k + 2;
    }
    // Replay the later samples from the corrected state.
    for (size_t j = first_replay; j < history_.size(); ++j) {
      history_[j] =
          Propagate(history_[j - 1], history_[j].time_s, history_[j].has_imu, history_[j].imu);
    }
  }
  last_pose_time_s_ = std::max(last_pose_time_s_, measured.time_s);
  last_correction_time_s_ = std::max(last_correction_time_s_, measured.time_s);
  Trim();
  return true;
}

void StateEstimator::Trim() {
  const double oldest = history_.back().time_s - config_.history_s;
  while (history_.size() > 1 && history_[1].time_s <= oldest) history_.pop_front();
}

VehicleState StateEstimator::state() const {
  KESTREL_DEMAND(initialized());
  const Node& node = history_.back();
  VehicleState state;
  state.position_m = node.position_m;
  state.velocity_mps = node.velocity_mps;
  state.R_WB = node.q_WB.toRotationMatrix();
  if (node.has_imu) state.angular_velocity_radps = node.imu.angular_velocity_radps - node.gyro_bias;
  return state;
}

}  // namespace kestrel

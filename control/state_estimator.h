#pragma once
/// @file
/// State estimation for the controller: IMU (gyro, accelerometer) propagation corrected by
/// motion-capture poses, with latency compensation. Frames as in control/vehicle_state.h (W z up,
/// B x forward, z up; gravity -g e3).
///
/// A complementary filter with a gyro-bias state (a fixed-gain, second-order observer per channel):
///  - Propagation, per IMU sample at time t_k over (t_(k-1), t_k] with that sample held:
///      q <- q Exp((omega_meas - b_g) dt),  a = R f_meas - g e3,  p <- p + v dt + a dt^2 / 2,
///      v <- v + a dt.
///  - Correction by a pose stamped t_m (acquisition time; it may arrive late): the estimate AT t_m
///    is taken from the history of propagated states, corrected, and the IMU samples after t_m are
///    replayed, so the current estimate includes the measurement without its latency:
///      e_p = p_meas - p,  p += k_p dt_m e_p,  v += k_v dt_m e_p          (k_p = 2 w_p, k_v =
///      w_p^2) e_th = Log(q^-1 q_meas) (body),  q <- q Exp(k_q dt_m e_th),  b_g -= k_b dt_m e_th
///    with dt_m the time since the previous correction (clamped to [min, max]_correction_dt_s).
///  - Attitude through dropouts: without poses the gyro keeps the attitude (bias-corrected) and
///    the accelerometer the velocity and position (they drift; the safety supervisor decides).
///  - A position innovation larger than reset_innovation_m (e.g. after a long dropout) snaps
///    position and attitude to the measurement (velocity and bias kept) and is counted.
/// Without IMU samples the same observer runs on poses alone (constant-velocity prediction).
/// No accelerometer bias is estimated (documented gap).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <deque>

#include "control/vehicle_state.h"

namespace kestrel {

/// Observer gains and buffers.
struct StateEstimatorConfig {
  double position_bandwidth_radps{6.0};  ///< w_p: position/velocity observer bandwidth, rad/s
  double attitude_gain_per_s{2.0};       ///< k_q: attitude correction rate, 1/s
  double gyro_bias_gain_per_s2{0.5};     ///< k_b: gyro-bias correction rate, 1/s^2
  double max_gyro_bias_radps{0.2};       ///< |b_g| clamp per axis, rad/s
  double history_s{0.5};  ///< how far back a late pose can be applied (>= the latency), s
  double min_correction_dt_s{0.001};  ///< lower clamp of dt_m, s
  double max_correction_dt_s{0.05};   ///< upper clamp of dt_m (a gap does not over-correct), s
  double reset_innovation_m{0.5};     ///< position innovation that snaps to the pose, m
  double gravity_mps2{9.81};          ///< g, m/s^2

  /// Throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// One IMU sample in the body frame.
struct ImuSample {
  double time_s{0.0};                                               ///< sample time, s
  Eigen::Vector3d angular_velocity_radps{Eigen::Vector3d::Zero()};  ///< gyro, B, rad/s
  Eigen::Vector3d specific_force_mps2{Eigen::Vector3d::Zero()};     ///< accelerometer, B, m/s^2
};

/// One motion-capture pose X_WB, stamped with its acquisition time.
struct PoseMeasurement {
  double time_s{0.0};                                       ///< acquisition time, s
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};      ///< p_WB, m
  Eigen::Quaterniond q_WB{Eigen::Quaterniond::Identity()};  ///< R_WB, unit
};

/// The estimator. Inputs in any interleaving; IMU samples must have increasing times. Pure (no
/// clock): times come with the inputs. Not thread-safe.
class StateEstimator {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit StateEstimator(const StateEstimatorConfig& config);

  /// Propagates with one IMU sample. Returns false (and ignores it) if a value is not finite or
  /// time_s is not after the latest sample; before the first pose the sample is dropped (false).
  bool AddImu(const ImuSample& sample);

  /// Corrects with a pose (the first one initialises the state at rest). Returns false (ignored)
  /// if a value is not finite, the quaternion is not unit within 1e-3, or the stamp is older than
  /// the history.
  bool AddPose(const PoseMeasurement& pose);

  [[nodiscard]] bool initialized() const { return !history_.empty(); }
  /// The estimate at time_s() (the latest input); W from the latest gyro minus bias (zero
  /// without an IMU). Precondition: initialized().
  [[nodiscard]] VehicleState state() const;
  /// Time of the current estimate, s. Precondition: initialized().
  [[nodiscard]] double time_s() const { return history_.back().time_s; }
  /// Stamp of the latest accepted pose, s (-inf before any).
  [[nodiscard]] double last_pose_time_s() const { return last_pose_time_s_; }
  [[nodiscard]] Eigen::Vector3d gyro_bias_radps() const { return history_.back().gyro_bias; }
  [[nodiscard]] int rejected_inputs() const { return rejected_inputs_; }
  [[nodiscard]] int resets() const { return resets_; }

 private:
  struct Node {
    double time_s{0.0};
    Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};
    Eigen::Vector3d velocity_mps{Eigen::Vector3d::Zero()};
    Eigen::Quaterniond q_WB{Eigen::Quaterniond::Identity()};
    Eigen::Vector3d gyro_bias{Eigen::Vector3d::Zero()};
    bool has_imu{false};  // imu: the sample that propagated the interval ending here
    ImuSample imu;
  };
  // The state of `from` propagated to time t_s with `imu` (if has_imu) held over the interval.
  [[nodiscard]] Node Propagate(const Node& from, double t_s, bool has_imu,
                               const ImuSample& imu) const;
  void Correct(const PoseMeasurement& pose, double dt_m_s, Node* node);
  void Trim();

  StateEstimatorConfig config_;
  std::deque<Node> history_;
  double last_pose_time_s_;
  double last_correction_time_s_;
  int rejected_inputs_{0};
  int resets_{0};
};

}  // namespace kestrel

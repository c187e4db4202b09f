#pragma once
/// @file
/// The flight-mode supervisor of the controller (pure: times come with the inputs, no I/O).
/// Modes: IDLE (motors off) -> TAKEOFF -> HOLD <-> TRACK -> LAND -> IDLE; ESTOP from anywhere,
/// latched until an IDLE command. TAKEOFF -> TRACK directly when a trajectory arrives once the
/// take-off set point has risen takeoff_track_min_rise_m (the explorer's start-up turn while
/// climbing, docs/exploration.md "Start-up: the turn while climbing"). Failsafes, checked on every
/// Update() in this order:
///  1. a non-finite state estimate while flying: ESTOP (nothing can be controlled);
///  2. the last valid pose older than land_timeout_s: LAND (on the IMU-propagated state; the
///     touchdown test then does not trust the estimated height, see blind_land_depth_m);
///  3. the last valid pose older than pose_timeout_s: HOLD (a "failsafe hold"); when poses return
///     within land_timeout_s the mode held before (TRACK) resumes (docs/design.md §2.4: a
///     loss shorter than the land time-out is flown on the IMU-propagated state and tracking
///     resumes when valid poses return; a longer one lands);
///  4. the vehicle outside the geofence by more than geofence_margin_m: LAND;
///  5. TRACK without a trajectory, or trajectory_timeout_s past its end: HOLD.
/// Set points are always finite and inside the geofence (clamped); trajectories that leave the
/// geofence are refused when they arrive, and so are trajectories that would be flown at once
/// (HOLD, TRACK) but start farther than max_trajectory_start_offset_m from the current set point:
/// the set point never jumps (docs/design.md §2.5: a far-start trajectory, e.g. planned before a
/// controller takeover, is refused and the explorer replans from the flown state).
/// A controller respawned within the same run takes a flying vehicle over where it is
/// (Takeover: HOLD, or LAND if it was landing; docs/design.md §2.5).

#include <Eigen/Core>
#include <optional>
#include <string>

#include "common/trajectory.h"
#include "control/vehicle_state.h"

namespace kestrel {

/// Flight modes (values as controller_status_t MODE_*: they go into the status message).
enum class FlightMode { kIdle = 0, kTakeoff = 1, kTrack = 2, kHold = 3, kLand = 4, kEstop = 5 };

/// How a refused far-start trajectory's reason begins (AcceptTrajectory; counted apart).
inline constexpr const char* kFarStartReason = "far start";

/// Operator / explorer commands (values as command_t COMMAND_*).
enum class FlightCommand { kIdle = 0, kTakeoff = 1, kTrack = 2, kHold = 3, kLand = 4, kEstop = 5 };

/// "IDLE", "TAKEOFF", ...
[[nodiscard]] const char* ToString(FlightMode mode);

/// Time-outs, take-off and landing profile and the geofence.
struct SafetyConfig {
  double pose_timeout_s{0.1};            ///< pose older than this: failsafe HOLD, s
  double land_timeout_s{2.0};            ///< pose older than this: LAND, s (docs/design.md §2.4)
  double trajectory_timeout_s{1.0};      ///< TRACK this long after the trajectory's end: HOLD, s
  double takeoff_height_m{1.0};          ///< climb above the take-off point, m
  double takeoff_speed_mps{0.5};         ///< climb rate of the take-off set point, m/s
  double takeoff_done_tolerance_m{0.1};  ///< position error that ends TAKEOFF (-> HOLD), m
  /// In TAKEOFF, a trajectory is accepted (and starts TRACK) only once the take-off set point has
  /// risen this far above the take-off point (the vehicle is off the ground); earlier it is
  /// refused. A take-off lower than this accepts trajectories in HOLD only, m.
  double takeoff_track_min_rise_m{0.2};
  double land_speed_mps{0.4};    ///< descent rate of the landing set point, m/s
  double landed_height_m{0.08};  ///< within this above the ground height: landed (-> IDLE), m
  double landed_speed_mps{0.3};  ///< and slower than this, m/s
  /// Landing without fresh poses ("blind", on the IMU-propagated estimate, whose height drifts:
  /// 0.4 m in 5 s in the simulator) cannot trust the height test above: it disarmed 0.2 m above
  /// the floor (tests/system/flight_modes_test.cc). Blind, the set point descends at
  /// land_speed_mps to this far below the ground height (below the geofence floor if need be:
  /// the floor stops the vehicle), m, and touchdown is declared when the set point gets there
  /// (so estimate drifts up to this depth end on the floor) or earlier when the set point is
  /// blind_landed_gap_m below the estimate while the estimate is slower than landed_speed_mps
  /// (the IMU saw the touchdown; in the air the vehicle follows the set point down).
  double blind_land_depth_m{1.0};
  double blind_landed_gap_m{0.3};  ///< see blind_land_depth_m, m (< blind_land_depth_m)
  /// Ground height when no take-off point is known (e.g. a failsafe before take-off), m.
  double default_ground_z_m{0.0};
  Eigen::Vector3d geofence_min_m{-4.0, -6.0, -0.2};  ///< geofence lower corner, W, m
  Eigen::Vector3d geofence_max_m{4.0, 6.0, 2.5};     ///< geofence upper corner, W, m
  double geofence_margin_m{0.3};  ///< tolerated excursion of the vehicle outside the fence, m
  /// A trajectory that would be flown at once (HOLD, TRACK) is refused when its set point now is
  /// farther than this from the current set point (no set-point step), m (> 0).
  double max_trajectory_start_offset_m{0.3};

  /// Throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// What the controller should do this step.
struct SafetyDecision {
  FlightMode mode{FlightMode::kIdle};  ///< current mode
  bool motors_enabled{false};          ///< false: rotors off (IDLE, ESTOP); no control law
  FlatOutput setpoint;                 ///< the desired flat output (finite, inside the fence)
  bool reset_integrals{true};          ///< zero the controller's integrals this step
  std::string reason;                  ///< why the last mode change happened
};

/// The supervisor. Not thread-safe.
class SafetySupervisor {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit SafetySupervisor(const SafetyConfig& config);

  /// Applies a command at time_s given the current estimate (nullptr if none). Returns false
  /// when it is refused in the current mode (e.g. TAKEOFF without a fresh pose, TRACK without a
  /// trajectory, anything but IDLE while in ESTOP); ESTOP is always accepted.
  /// `takeoff_height_m` (m, TAKEOFF only): climb height; not finite or <= 0: the configured one.
  bool HandleCommand(FlightCommand command, double time_s, const VehicleState* state,
                     double last_pose_time_s, double takeoff_height_m = 0.0);

  /// Stores a new trajectory if every point (sampled every 0.05 s) is inside the geofence and, in
  /// TAKEOFF, the take-off set point has risen takeoff_track_min_rise_m; in TAKEOFF, HOLD (not a
  /// failsafe hold) or TRACK it (re)starts TRACK. Returns false with *reason when refused (the
  /// previous trajectory stays).
  bool AcceptTrajectory(const PiecewisePolynomialTrajectory& trajectory, double time_s,
                        std::string* reason);

  /// Takes a flying vehicle over after a controller restart (docs/design.md §2.5): from IDLE
  /// only, with a valid `state` and a pose fresher than pose_timeout_s, the set point becomes the
  /// estimate (position, yaw; zero velocity) and the mode HOLD, or LAND when `landing`;
  /// `ground_z_m` (m, finite) is the take-off ground height the landing ends on. Returns false
  /// with *reason when refused.
  bool Takeover(double time_s, const VehicleState& state, double last_pose_time_s,
                double ground_z_m, bool landing, std::string* reason);
  /// The ground height the landing ends on (the take-off point's, or default_ground_z_m), m.
  [[nodiscard]] double ground_z_m() const { return ground_z_m_; }

  /// One step: failsafes, mode progress, set point. `state` may be nullptr (no estimate yet);
  /// last_pose_time_s is the stamp of the latest valid pose (-inf if none). A non-finite time_s
  /// returns the previous decision unchanged.
  SafetyDecision Update(double time_s, const VehicleState* state, double last_pose_time_s);

  [[nodiscard]] FlightMode mode() const { return decision_.mode; }
  [[nodiscard]] const SafetyDecision& last_decision() const { return decision_; }

 private:
  void Enter(FlightMode mode, double time_s, const std::string& reason);
  [[nodiscard]] FlatOutput Clamp(FlatOutput setpoint) const;
  [[nodiscard]] bool PoseFresh(double time_s, double last_pose_time_s, double limit_s) const;

  SafetyConfig config_;
  SafetyDecision decision_;
  std::optional<PiecewisePolynomialTrajectory> trajectory_;
  double mode_start_time_s_{0.0};
  FlatOutput mode_start_setpoint_;  // set point when the mode began (hold, land, take-off)
  double ground_z_m_;
  double takeoff_height_m_;
  bool failsafe_hold_{false};  // HOLD entered because the pose went stale
  FlightMode resume_mode_{FlightMode::kHold};
};

}  // namespace kestrel

#pragma once
/// @file
/// Whether a controller respawned within a run takes the vehicle over (docs/design.md §2.5). Pure:
/// the node reads the previous controller's state file into a PreviousFlight, and asks
/// DecideTakeover at every control step, with its clock's time and its estimator's state, until
/// the answer is no longer kWait.
///
/// The vehicle counts as airborne when both say so:
///  - the state file of the same run: the previous controller was flying (TAKEOFF, HOLD, TRACK or
///    LAND) at its last life sign `alive_s` (it refreshes the file while flying);
///  - a fresh pose (no older than pose_timeout_s): the estimate more than landed_height_m above
///    the take-off ground height, or faster than landed_speed_mps.
/// Neither the time the process took to come back nor the time its first pose took decides: the
/// node waits for a fresh pose however late it comes, and sends no motor command meanwhile (the
/// ESC hold keeps the previous controller's last command). The evidence is stale, and the vehicle
/// is not taken over, when the first fresh pose is more than max_gap_s after the previous
/// controller's last life sign: no vehicle stays up on its own rotors that long without a
/// controller (the ESC hold, 1.5 s, and a fall from the geofence's top take about 2.5 s), so one
/// still seen off the ground is held by something else (a hand, a tether), and arming it would
/// spin its rotors up there. A pose stamped well before the last life sign (another clock, a new
/// simulation with the run's id) is inconsistent evidence, treated alike.

#include <string>

#include "control/safety.h"
#include "control/vehicle_state.h"

namespace kestrel {

/// What the previous controller of this run left in its state file (common/run_state_file.h).
struct PreviousFlight {
  bool landing{false};   ///< it was in LAND (else TAKEOFF, HOLD or TRACK)
  double ground_z_m{0};  ///< its take-off ground height, m
  double alive_s{0};     ///< its last life sign: the file's stamp, s (the controller's clock)
};

/// What DecideTakeover says.
enum class TakeoverVerdict {
  kWait,      ///< no fresh pose yet: keep waiting, send nothing
  kHold,      ///< airborne: take it over in HOLD where it is
  kLand,      ///< airborne and it was landing: take it over in LAND
  kStayIdle,  ///< not airborne, or the evidence is stale: IDLE, motors off
};

/// "WAIT", "HOLD", "LAND", "STAY_IDLE".
[[nodiscard]] const char* ToString(TakeoverVerdict verdict);

/// The verdict and why.
struct TakeoverDecision {
  TakeoverVerdict verdict{TakeoverVerdict::kWait};
  std::string reason;  ///< one line for the log and the heartbeat
};

/// Decides, at `time_s` (s), whether the vehicle the previous controller flew is airborne (file
/// comment). `state` is the estimator's (nullptr: not initialised yet), `last_pose_time_s` the
/// stamp of its newest valid pose (s, -inf if none); `safety` gives pose_timeout_s,
/// landed_height_m and landed_speed_mps; `max_gap_s` (> 0) bounds the time between the previous
/// controller's last life sign and the first fresh pose.
[[nodiscard]] TakeoverDecision DecideTakeover(const PreviousFlight& previous, double time_s,
                                              const VehicleState* state, double last_pose_time_s,
                                              const SafetyConfig& safety, double max_gap_s);

}  // namespace kestrel

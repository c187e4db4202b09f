#pragma once
/// @file
/// The explorer's start-up turn (docs/exploration.md, "Start-up: the turn while climbing"): one
/// trajectory that takes the vehicle from the state it is in (climbing on the controller's
/// take-off, or hovering) to the exploration height h, vertically, while its heading turns one
/// full circle (+2 pi) to scan the surroundings before the first plan.
///  - x and y stay at the start's position for the whole trajectory (no lateral motion: the start's
///    horizontal velocity and acceleration are dropped, a take-off climbs vertically).
///  - z: one degree-7 polynomial from the start's z, vertical velocity and acceleration (zero
///    jerk: the take-off set point climbs at constant speed) to rest at h (velocity, acceleration
///    and jerk zero); its duration is the shortest, on a 1% grid, whose samples respect
///    max_speed_mps and max_acceleration_mps2 and stay between the start's z and h (2 cm of
///    tolerance); if none does (a start moving away from h, or too fast to stop at h), the
///    shortest that stays within 3 v0^2 / max_acceleration_mps2 (plus 2 cm) beyond the side the
///    start velocity v0 points to.
///  - yaw: +2 pi from the start's heading, with the peak yaw rate, either
///    smoothstep (the default, the former turn): yaw0 + 2 pi s(tau / T) with the degree-7
///    smoothstep s, peak rate 35/16 * 2 pi / T: 17.2 s at 0.8 rad/s; or
///    ramped: the trajectory planner's YawProfile (exploration/trajectory_planner.h): the rate
///    ramps up in 0.75 s (cubic smoothstep of the rate, yaw acceleration at most 2 peak per
///    second), cruises at the peak and ramps down: 8.6 s at 0.8 rad/s.
///  - The two overlap from the start; the shorter holds its end value until the longer ends. The
///    pieces are split at the union of both profiles' knots (Taylor shifts).
/// Position, velocity and acceleration in z and the yaw are continuous with the start (its yaw
/// rate is taken as zero: take-off and hover do not turn). Pure, no I/O.

#include <optional>
#include <string>

#include "common/trajectory.h"

namespace kestrel {

/// How the heading turns its full circle (file comment).
enum class StartupYawProfile { kSmoothstep, kRamped };

/// Limits of the start-up trajectory.
struct StartupTurnLimits {
  double max_speed_mps{1.0};          ///< vertical speed limit, m/s (> 0)
  double max_acceleration_mps2{1.0};  ///< vertical acceleration limit, m/s^2 (> 0)
  double peak_yaw_rate_radps{0.8};    ///< peak yaw rate of the full circle, rad/s (> 0)
  StartupYawProfile yaw_profile{StartupYawProfile::kSmoothstep};  ///< see the file comment
};

/// The start-up trajectory from `start` (its time_s is the trajectory's start) to rest at
/// (start x, start y, height_m) after a full circle in yaw (file comment). Returns std::nullopt
/// with *error (if non-null) when the start is not finite, the limits are not positive, or no
/// duration up to 60 s meets the limits (e.g. a start velocity far above max_speed_mps).
[[nodiscard]] std::optional<PiecewisePolynomialTrajectory> PlanStartupTurn(
    const TrajectoryStart& start, double height_m, const StartupTurnLimits& limits,
    std::string* error);

}  // namespace kestrel

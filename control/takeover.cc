#include "control/takeover.h"

#include <cmath>
#include <cstdio>

namespace kestrel {

namespace {

// A pose may be stamped a little before the previous controller's last life sign (it was
// acquired before that step ran); this much earlier is still the same clock, s.
constexpr double kClockSlackS = 1.0;

TakeoverDecision Decision(TakeoverVerdict verdict, const char* format, double a, double b = 0,
                          double c = 0) {
  char text[240];
  std::snprintf(text, sizeof(text), format, a, b, c);
  return {verdict, text};
}

}  // namespace

const char* ToString(TakeoverVerdict verdict) {
  switch (verdict) {
    case TakeoverVerdict::kWait:
      return "WAIT";
    case TakeoverVerdict::kHold:
      return "HOLD";
    case TakeoverVerdict::kLand:
      return "LAND";
    case TakeoverVerdict::kStayIdle:
      return "STAY_IDLE";
  }
  return "?";
}

TakeoverDecision DecideTakeover(const PreviousFlight& previous, double time_s,
                                const VehicleState* state, double last_pose_time_s,
                                const SafetyConfig& safety, double max_gap_s) {
  if (state == nullptr || !state->IsValid(1e-3)) {
    return {TakeoverVerdict::kWait, "waiting for the first pose to judge whether it flies"};
  }
  const double pose_age_s = time_s - last_pose_time_s;
  if (!(pose_age_s <= safety.pose_timeout_s)) {
    return Decision(TakeoverVerdict::kWait,
                    "waiting for a fresh pose: the newest is %.3f s old (pose_timeout_s %.3f s)",
                    pose_age_s, safety.pose_timeout_s);
  }
  const double gap_s = last_pose_time_s - previous.alive_s;
  if (!(gap_s >= -kClockSlackS)) {
    return Decision(TakeoverVerdict::kStayIdle,
                    "no takeover: the first fresh pose (%.3f s) is stamped %.3f s before the "
                    "previous controller's last life sign (another clock or another run)",
                    last_pose_time_s, -gap_s);
  }
  if (!(gap_s <= max_gap_s)) {
    return Decision(TakeoverVerdict::kStayIdle,
                    "no takeover: the first fresh pose comes %.3f s after the previous "
                    "controller's last life sign, more than takeover_max_gap_s = %.3f s (stale: "
                    "whatever holds the vehicle up now is not its rotors)",
                    gap_s, max_gap_s);
  }
  const double height_m = state->position_m.z() - previous.ground_z_m;
  const double speed_mps = state->velocity_mps.norm();
  if (height_m <= safety.landed_height_m && speed_mps < safety.landed_speed_mps) {
    return Decision(TakeoverVerdict::kStayIdle,
                    "no takeover: the vehicle is on the ground (%.3f m above its take-off "
                    "ground, %.3f m/s)",
                    height_m, speed_mps);
  }
  return Decision(previous.landing ? TakeoverVerdict::kLand : TakeoverVerdict::kHold,
                  "airborne: %.3f m above its take-off ground at %.3f m/s, %.3f s after the "
                  "previous controller's last life sign",
                  height_m, speed_mps, gap_s);
}

}  // namespace kestrel

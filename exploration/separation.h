#pragma once
/// @file
/// Several vehicles in one building (docs/exploration.md, "Several vehicles"): where another
/// vehicle will be, and the smallest distance between a trajectory and every other vehicle over
/// time. A vehicle flies the trajectory it published last and, when it ends, holds at its end
/// until it publishes another; a vehicle with no trajectory (on the ground, or holding after
/// take-off) stays where it was seen last, and so does one seen after its trajectory's end
/// (holding there, or landed). Two vehicles are apart by their horizontal distance while their
/// heights differ by less than a vertical separation; one that flies that far above another (a
/// landed one) is clear of it. Pure: no LCM, no clock.

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/trajectory.h"

namespace kestrel {

/// What one explorer knows of another vehicle's motion.
struct PeerMotion {
  std::string name;  ///< its channel prefix, for messages
  /// Its last published trajectory (absolute times on the shared clock), if any.
  std::optional<PiecewisePolynomialTrajectory> trajectory;
  /// Where it was seen last (motion capture), m, W; used before its trajectory starts and when it
  /// has none.
  Eigen::Vector3d position_m{Eigen::Vector3d::Zero()};
  bool seen{false};                ///< position_m holds a pose
  double position_time_s{-1e300};  ///< when it was seen there (the trajectories' time base), s
};

/// Where `peer` is expected at t_s: its trajectory's set point from the trajectory's start on
/// (its end position after the end), unless it was seen after that end; else its last seen
/// position. nullopt if it has neither.
[[nodiscard]] std::optional<Eigen::Vector3d> PeerPositionAt(const PeerMotion& peer, double t_s);

/// The separation between a vehicle at own_m and `peer` at t_s: their horizontal distance while
/// their heights differ by less than vertical_m, else (or if the peer is unknown) infinite, m.
[[nodiscard]] double SeparationAt(const Eigen::Vector3d& own_m, const PeerMotion& peer, double t_s,
                                  double vertical_m);

/// The closest approach of a trajectory to the other vehicles.
struct Separation {
  /// Smallest horizontal distance while the heights differ by less than the vertical separation
  /// (infinite if never), m.
  double distance_m{std::numeric_limits<double>::infinity()};
  double time_s{0.0};  ///< when (absolute, the trajectories' time base), s
  std::string peer;    ///< which vehicle ("" if none was known)
};

/// The smallest horizontal distance between `own` (from from_s, then holding at its end) and
/// every peer at the instants their heights differ by less than vertical_m, sampled every dt_s
/// from from_s to the last end time among `own` and the peers' trajectories, plus hold_s (both
/// holding at their ends by then). Precondition: dt_s > 0, from_s finite.
[[nodiscard]] Separation ClosestApproach(const PiecewisePolynomialTrajectory& own, double from_s,
                                         const std::vector<PeerMotion>& peers, double vertical_m,
                                         double dt_s = 0.1, double hold_s = 1.0);

/// The goals other vehicles fly to: each peer's trajectory end (x, y, yaw), for
/// PlannerInput::peer_goals.
[[nodiscard]] std::vector<Eigen::Vector3d> PeerGoals(const std::vector<PeerMotion>& peers);

}  // namespace kestrel

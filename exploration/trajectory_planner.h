#pragma once
/// @file
/// From a chosen candidate to a trajectory (docs/algorithms.md §10; non-stop flight:
/// docs/exploration.md, section "Non-stop flight"):
///  1. Dijkstra back-pointers give the cell path; waypoints are the vehicle's position, then the
///     centres of the path's cells (the start cell's included) up to the goal cell's centre.
///  2. Line-of-sight pruning: from each kept waypoint, jump to the farthest later one whose
///     straight segment keeps the vehicle's DISC (radius r) inside allowed cells (the swept
///     capsule is tested exactly against every cell square).
///  3. Time allocation from a speed profile along the whole pruned polyline. The speed at an
///     interior waypoint is limited by its turn (bounded lateral acceleration): the velocity turns
///     by the angle theta between the legs while the vehicle covers 2w around the waypoint, so its
///     mean lateral acceleration 2 v sin(theta/2) / (2w / v) <= max_acceleration gives
///     v <= sqrt(max_acceleration w / sin(theta/2)) (0 for a U-turn); w is an eighth of the
///     shorter half-leg, at most of 1 s at max_speed (the polynomial pinned at the waypoint turns
///     its velocity that close to it). Legs are split into pieces of at most 0.5 s at max_speed,
///     with no added point within 1 s at max_speed of a turn or of the start (room to turn the
///     velocity). A forward pass from the start speed (the start velocity's projection on the
///     first leg), a backward pass to rest at the goal and the max_speed cap give the speed at
///     every waypoint; each piece's duration is that of accelerate-cruise-decelerate between its
///     end speeds at 2/3 max_acceleration (the time and distance of a cubic-smoothstep speed
///     change peaking at max_acceleration), at least min_segment_duration_s. Up to three times
///     the profile's speed and acceleration are lowered by the sampled overshoot of the
///     polynomial (step 4) and the durations recomputed.
///  4. A piecewise polynomial of degree 2k-1 (k = 4: minimum snap, k = 3: minimum jerk) through
///     the waypoints (x, y at the waypoints, z from the vehicle's height to h), minimising the
///     integral of the squared k-th derivative subject to: positions at every waypoint, the start
///     state's velocity AND acceleration (the jerk at the start is left free, so a replan spliced
///     onto the old trajectory is continuous in position, velocity and acceleration, see Splice()
///     in common/trajectory.h), rest at the goal, and continuity of derivatives 1..k (up to snap,
///     or jerk) at interior waypoints: the vehicle does not stop there. All axes are solved as ONE
///     KKT system [2Q A^T; A 0] with Eigen (one factorisation, three right-hand sides), each
///     segment in normalised time for conditioning. Safety net: all durations scaled up
///     uniformly until the sampled speed and acceleration respect the limits (the yaw rate
///     respects its limit by construction, step 5).
///  5. Yaw turns from the start yaw and yaw rate to the candidate's heading along the shortest
///     way WHILE translating, over its own duration: the yaw rate ramps (cubic smoothsteps,
///     yaw acceleration at most 2 max_yaw_rate per second) from the start's rate, which stays
///     continuous, to at most max_yaw_rate, cruises and ramps to 0; the shortest such profile
///     (this bound on the ramps is its floor), then the heading holds. The trajectory's pieces
///     are split where the yaw profile changes piece (Taylor shifts); when the turn outlasts the
///     flight, the vehicle hovers at the goal until it ends. The yaw rate respects max_yaw_rate
///     by construction (unless the start's rate exceeds it).
///  6. Check: samples every sample_period_s keep the disc inside allowed cells. Repair: insert the
///     midpoint of every straight segment whose polynomial piece fails and re-solve (up to
///     max_repair_rounds); then make the vehicle rest at both ends of every failing piece
///     (derivatives 1..k-1 zero there), round after round: a piece between two rests stays on its
///     straight, line-of-sight-checked segment, so the repair ends (with a start velocity of 0).
///  The start state is used exactly first; if the time allocation does not converge or the
///  repair fails with it, the planner retries from the start velocity's component along the first
///  leg (at most 0.9 max_speed, zero acceleration), then from rest (the controller absorbs the
///  step in the set point's velocity); TrajectoryPlan::start_matched tells which.
/// Allowed cells: traversable cells of C, plus the cells the square of half-width r around the
/// start position overlaps (the vehicle is already there), except cells other than the vehicle's
/// own that are known occupied (P(C) > 0.5): those are allowed only on the pieces before the
/// start cell's centre, which is then kept
/// as a waypoint, so a vehicle whose disc grazes a door frame first moves back to the middle of
/// its cell and never cuts the corner through the frame.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/trajectory.h"
#include "exploration/dijkstra.h"
#include "exploration/grid_map_2d.h"
#include "exploration/traversability.h"

namespace kestrel {

/// Parameters of the trajectory generation.
struct TrajectoryConfig {
  double max_speed_mps{1.0};           ///< speed limit, m/s (> 0)
  double max_acceleration_mps2{1.0};   ///< acceleration limit, m/s^2 (> 0)
  double max_yaw_rate_radps{1.0};      ///< yaw-rate limit, rad/s (> 0)
  int derivative_order{4};             ///< k: 4 minimum snap (degree 7), 3 minimum jerk (5)
  double sample_period_s{0.01};        ///< check and display sampling, s (> 0)
  double vehicle_radius_m{0.44};       ///< disc radius r checked against C, m (> 0)
  double min_segment_duration_s{0.3};  ///< floor on each piece's duration, s (> 0)
  int max_repair_rounds{2};            ///< midpoint insertion rounds before adding rests

  /// @throws std::invalid_argument naming the field, its value and the accepted range.
  void Validate() const;
};

/// What PlanTrajectory produced.
struct TrajectoryPlan {
  std::optional<PiecewisePolynomialTrajectory> trajectory;  ///< empty on failure
  /// The position at every knot of the trajectory, its end included: the waypoints finally used
  /// (after pruning, splitting of long legs, repair), plus the points where the yaw profile
  /// changes piece and, when the turn outlasts the flight, the goal again.
  std::vector<Eigen::Vector3d> waypoints;
  std::vector<int> cell_path;  ///< Dijkstra's cells, start to goal
  int unpruned_waypoints{0};   ///< before line-of-sight pruning
  int repair_rounds{0};        ///< midpoint insertion rounds used
  int stop_waypoints{0};       ///< interior waypoints where the vehicle rests
  bool start_matched{false};   ///< trajectory starts with the start's velocity and acceleration
  double yaw_duration_s{0.0};  ///< duration of the turn to the goal's heading, s
  std::string error;           ///< why there is no trajectory
};

/// One piece of a yaw profile: duration (s) and coefficients (ascending powers of its local
/// time, rad).
struct YawPiece {
  double duration_s{0.0};
  std::vector<double> coefficients;
};

/// The yaw profile of step 5 of the file comment: from yaw0 (rad) at rate rate0 (rad/s), turn by
/// delta (rad, not wrapped: 2 pi is a full circle) and rest. The rate ramps from rate0 to a peak
/// (at most max_rate in magnitude), cruises, ramps to 0; each ramp is a cubic smoothstep of the
/// rate (yaw acceleration continuous, at most 2 max_rate per second: a ramp from 0 to max_rate
/// takes 0.75 s), so the duration is the shortest that respects max_rate and that yaw
/// acceleration. The last piece is the hold at the end (its duration 0, unused).
[[nodiscard]] std::vector<YawPiece> YawProfile(double yaw0, double rate0, double delta,
                                               double max_rate);

/// Whether the disc of radius r at p overlaps only cells with allowed[i] (and no cell outside the
/// grid). Overlap means a distance < r from p to the cell's square.
[[nodiscard]] bool DiscClear(const GridMap2D& grid, const std::vector<bool>& allowed,
                             const Eigen::Vector2d& p, double radius_m);

/// Whether the capsule swept by the disc of radius r along [a, b] overlaps only allowed cells.
[[nodiscard]] bool SegmentClear(const GridMap2D& grid, const std::vector<bool>& allowed,
                                const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                double radius_m);

/// The fine modes' preferred clearance (docs/exploration.md, "Traversability"), for pruning: a
/// shortcut must keep, at every point of it, a clearance of at least min(preferred_m, the least
/// clearance at the points it replaces) - alpha/2, so that pruning does not take back the room
/// the clearance-weighted search chose (cut a shelf's end at the margin).
/// Passages (exploration/traversability.h, step 3b): a path crosses a cell with a path point
/// there, not at its centre; in such a cell the clearance counts less the offset across the
/// passage from the point, and the sampled trajectory (and every shortcut) must keep within the
/// cell's tolerance of the point across the passage (path_across; alpha/2 without it).
struct PathClearance {
  const GridMap2D* clearance{nullptr};  ///< per cell, m (Traversability::clearance); null: off
  double preferred_m{0.0};              ///< radius + margin + the preferred extra, m
  /// Cells a path crosses at a point other than their centre (Traversability::passage_points,
  /// the middle of a passage), by index; null: none.
  const std::unordered_map<int, Eigen::Vector2d>* path_points{nullptr};
  /// Per such cell, the direction across its passage and the tolerance (Traversability::
  /// passage_across); null or missing: across the cell edge the point lies on, alpha/2.
  const std::unordered_map<int, PassageAcross>* path_across{nullptr};
};

/// Greedy line-of-sight pruning of `points` (step 2 of the file comment): keeps the first and
/// last point; with `clearance`, shortcuts also keep its preferred clearance (PathClearance).
/// Precondition: consecutive points are SegmentClear.
[[nodiscard]] std::vector<Eigen::Vector2d> PruneWaypoints(
    const GridMap2D& grid, const std::vector<bool>& allowed,
    const std::vector<Eigen::Vector2d>& points, double radius_m,
    const PathClearance& clearance = {});

/// The polynomial pieces through points[0..S] with durations[0..S-1] (step 4 of the file
/// comment). start_velocity_mps at the start and derivatives 2..k-1 zero there (a start at
/// constant velocity); rest at the end; stop_at[i] (empty: none) puts a rest (derivatives 1..k-1
/// zero on both sides) at interior waypoint i instead of continuity. Yaw is left zero. The KKT
/// system is sparse (Eigen::SparseLU).
/// Returns nullopt if the KKT system cannot be solved.
/// @throws std::invalid_argument on inconsistent sizes, k outside {3, 4} or a duration <= 0.
[[nodiscard]] std::optional<std::vector<PolynomialSegment>> SolveMinimumDerivative(
    const std::vector<Eigen::Vector3d>& points, const std::vector<double>& durations_s,
    int derivative_order, const Eigen::Vector3d& start_velocity_mps,
    const std::vector<bool>& stop_at = {});

/// The same from a start in velocity AND acceleration: start_velocity_mps and
/// start_acceleration_mps2 at the start, the start's jerk (k = 4) left FREE (the minimum-snap
/// optimum chooses it: a replan cannot match the old trajectory's jerk anyway, and a free jerk
/// lets the acceleration build up at once); rest at the end, continuity or stop_at as above.
[[nodiscard]] std::optional<std::vector<PolynomialSegment>> SolveMinimumDerivative(
    const std::vector<Eigen::Vector3d>& points, const std::vector<double>& durations_s,
    int derivative_order, const Eigen::Vector3d& start_velocity_mps,
    const Eigen::Vector3d& start_acceleration_mps2, const std::vector<bool>& stop_at = {});

/// The whole step from a goal cell of `field` to a checked trajectory starting at start.time_s
/// from the start state (file comment): in flight, StateAt(current trajectory, t_splice) with
/// t_splice a little ahead, the result then published through Splice() (common/trajectory.h).
/// `collision` gives the geometry of C; traversable its eq. (13) flags. The goal is the centre
/// of goal_cell at height_m with heading goal_yaw_rad.
/// @throws std::invalid_argument if config is invalid, sizes disagree or the start state, goal
/// yaw or height is not finite.
/// `clearance` (optional) is passed to PruneWaypoints.
[[nodiscard]] TrajectoryPlan PlanTrajectory(const GridMap2D& collision,
                                            const std::vector<bool>& traversable,
                                            const DistanceField& field, int goal_cell,
                                            const TrajectoryStart& start, double goal_yaw_rad,
                                            double height_m, const TrajectoryConfig& config,
                                            const PathClearance& clearance = {});

/// The same from a start at position, velocity and yaw, with zero acceleration and yaw rate.
[[nodiscard]] TrajectoryPlan PlanTrajectory(
    const GridMap2D& collision, const std::vector<bool>& traversable, const DistanceField& field,
    int goal_cell, const Eigen::Vector3d& start_position_m,
    const Eigen::Vector3d& start_velocity_mps, double start_yaw_rad, double goal_yaw_rad,
    double height_m, double start_time_s, const TrajectoryConfig& config);

/// A stop (docs/exploration.md, "Non-stop flight", section 1): from `start` (position, velocity,
/// acceleration, yaw and yaw rate, matched exactly) to rest on the line of the start velocity, one
/// minimum-derivative piece whose duration grows until its sampled acceleration is within
/// max_acceleration (or within the start's own, if that is larger); the yaw rate falls linearly to
/// 0. What the explorer flies when a replan cannot start from the flown state: braking at once
/// instead of a step in the set point's velocity. nullopt if the start is not finite or no
/// duration meets the limit.
[[nodiscard]] std::optional<PiecewisePolynomialTrajectory> PlanStop(const TrajectoryStart& start,
                                                                    const TrajectoryConfig& config);

/// Whether the rest of `trajectory` from from_time_s on (sampled every sample_period_s, its end
/// included) keeps the disc of radius_m inside `allowed` cells of a (new) collision map: the
/// explorer's "the map made the remaining path unsafe" test (replan when false).
[[nodiscard]] bool RemainingPathClear(const PiecewisePolynomialTrajectory& trajectory,
                                      double from_time_s, const GridMap2D& collision,
                                      const std::vector<bool>& allowed, double radius_m,
                                      double sample_period_s = 0.01);

/// The allowed cells of the file comment: traversable, plus those overlapped by the square of
/// half-width radius_m around start_xy.
[[nodiscard]] std::vector<bool> AllowedCells(const GridMap2D& collision,
                                             const std::vector<bool>& traversable,
                                             const Eigen::Vector2d& start_xy, double radius_m);

}  // namespace kestrel

#pragma once
/// @file
/// From a chosen candidate to a trajectory (ALGORITHMS.md section 8, "Path"):
///  1. Dijkstra back-pointers give the cell path; waypoints are the vehicle's position, then the
///     centres of the path's cells (the start cell's included) up to the goal cell's centre.
///  2. Line-of-sight pruning: from each kept waypoint, jump to the farthest later one whose
///     straight segment keeps the vehicle's DISC (radius r) inside allowed cells (the swept
///     capsule is tested exactly against every cell square).
///  3. A piecewise polynomial of degree 2k-1 (k = 4: minimum snap, k = 3: minimum jerk) through
///     the waypoints (x, y at the waypoints, z from the vehicle's height to h), minimising the
///     integral of the squared k-th derivative subject to: positions at every waypoint, the
///     vehicle's velocity and zero higher derivatives at the start, rest at the goal, and
///     continuity of derivatives 1..k (up to snap, or jerk) at interior waypoints. All axes are
///     solved as ONE KKT system [2Q A^T; A 0] with Eigen (one factorisation, three right-hand
///     sides), each segment in normalised time for conditioning. Durations: trapezoidal profile
///     per segment from the speed and acceleration limits, then scaled up uniformly until the
///     sampled speed, acceleration and yaw rate respect the limits.
///  4. Yaw turns from the vehicle's heading to the candidate's along the shortest way with a
///     rest-to-rest polynomial (the smoothstep of the same degree) over the whole duration.
///  5. Check: samples every sample_period_s keep the disc inside allowed cells. Repair: insert the
///     midpoint of every straight segment whose polynomial piece fails and re-solve (up to
///     max_repair_rounds); then make the vehicle rest at both ends of every failing piece
///     (derivatives 1..k-1 zero there), round after round: a piece between two rests stays on its
///     straight, line-of-sight-checked segment, so the repair ends (with a start velocity of 0).
/// Allowed cells: traversable cells of C, plus the cells the square of half-width r around the
/// start position overlaps (the vehicle is already there), except cells other than the vehicle's
/// own that are known occupied (P(C) > 0.5): those are allowed only on the pieces before the
/// start cell's centre, which is then kept
/// as a waypoint, so a vehicle whose disc grazes a door frame first moves back to the middle of
/// its cell and never cuts the corner through the frame.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "common/trajectory.h"
#include "exploration/dijkstra.h"
#include "exploration/grid_map_2d.h"

namespace kestrel {

/// Parameters of the trajectory generation.
struct TrajectoryConfig {
  double max_speed_mps{0.5};           ///< speed limit, m/s (> 0)
  double max_acceleration_mps2{0.5};   ///< acceleration limit, m/s^2 (> 0)
  double max_yaw_rate_radps{0.6};      ///< yaw-rate limit, rad/s (> 0)
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
  std::vector<Eigen::Vector3d> waypoints;  ///< the waypoints finally used (after pruning, repair)
  std::vector<int> cell_path;              ///< Dijkstra's cells, start to goal
  int unpruned_waypoints{0};               ///< before line-of-sight pruning
  int repair_rounds{0};                    ///< midpoint insertion rounds used
  int stop_waypoints{0};                   ///< interior waypoints where the vehicle rests
  std::string error;                       ///< why there is no trajectory
};

/// Whether the disc of radius r at p overlaps only cells with allowed[i] (and no cell outside the
/// grid). Overlap means a distance < r from p to the cell's square.
[[nodiscard]] bool DiscClear(const GridMap2D& grid, const std::vector<bool>& allowed,
                             const Eigen::Vector2d& p, double radius_m);

/// Whether the capsule swept by the disc of radius r along [a, b] overlaps only allowed cells.
[[nodiscard]] bool SegmentClear(const GridMap2D& grid, const std::vector<bool>& allowed,
                                const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                double radius_m);

/// Greedy line-of-sight pruning of `points` (step 2 of the file comment): keeps the first and
/// last point. Precondition: consecutive points are SegmentClear.
[[nodiscard]] std::vector<Eigen::Vector2d> PruneWaypoints(
    const GridMap2D& grid, const std::vector<bool>& allowed,
    const std::vector<Eigen::Vector2d>& points, double radius_m);

/// The polynomial pieces through points[0..S] with durations[0..S-1] (step 3 of the file
/// comment). start_velocity_mps at the start; rest at the end; stop_at[i] (empty: none) puts a
/// rest (derivatives 1..k-1 zero on both sides) at interior waypoint i instead of continuity.
/// Yaw is left zero. The KKT system is sparse (Eigen::SparseLU).
/// Returns nullopt if the KKT system cannot be solved.
/// @throws std::invalid_argument on inconsistent sizes, k outside {3, 4} or a duration <= 0.
[[nodiscard]] std::optional<std::vector<PolynomialSegment>> SolveMinimumDerivative(
    const std::vector<Eigen::Vector3d>& points, const std::vector<double>& durations_s,
    int derivative_order, const Eigen::Vector3d& start_velocity_mps,
    const std::vector<bool>& stop_at = {});

/// The whole step from a goal cell of `field` to a checked trajectory starting at start_time_s
/// (file comment). `collision` gives the geometry of C; traversable its eq. (13) flags.
/// @throws std::invalid_argument if config is invalid or sizes disagree.
[[nodiscard]] TrajectoryPlan PlanTrajectory(
    const GridMap2D& collision, const std::vector<bool>& traversable, const DistanceField& field,
    int goal_cell, const Eigen::Vector3d& start_position_m,
    const Eigen::Vector3d& start_velocity_mps, double start_yaw_rad, double goal_yaw_rad,
    double height_m, double start_time_s, const TrajectoryConfig& config);

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

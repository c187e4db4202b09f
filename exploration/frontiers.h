#pragma once
/// @file
/// Frontiers on the fine traversability (docs/exploration.md, "The frontier baseline"): the
/// pieces of the nearest-frontier baseline (Yamauchi 1997) that look at the band, as pure
/// functions. A FRONTIER CELL is an unknown band cell (Traversability::unknown) with a known-free
/// band cell (band P <= free_threshold) among its four neighbours: the edge of the known free
/// space. Unknown cells enclosed by occupied ones (the inside of a solid block, the space behind
/// a wall) are not frontiers, however many there are. No LCM, no clock.

#include <Eigen/Core>
#include <vector>

#include "exploration/grid_map_2d.h"
#include "exploration/traversability.h"

namespace kestrel {

/// Per band cell, x fastest: whether it is a frontier cell (file comment).
[[nodiscard]] std::vector<bool> FrontierCells(const Traversability& map, double free_threshold);

/// Band P above which a band cell is known occupied (Traversability: unknown is [P_init/2, 0.5]).
inline constexpr double kOccupiedBandP = 0.5;

/// Whether the band cell `to` is in sight from the point `from_m`: every cell the 2D segment
/// between their centres crosses before `to` has band P <= max_crossed_p. With the free
/// threshold (a goal's sight) it is strict: a cell past uncertain space counts as not in sight.
/// With kOccupiedBandP (what a reached view covered) only known occupied cells hide it.
[[nodiscard]] bool InSight(const GridMap2D& band, const Eigen::Vector2d& from_m, int to,
                           double max_crossed_p);

/// A view of the frontier cells from one pose: what the vehicle's camera covers in the plane.
struct FrontierView {
  double min_range_m{0.7};         ///< nearer cells are not covered (the camera's minimum range)
  double max_range_m{3.0};         ///< farther cells are not covered, m
  double horizontal_fov_rad{1.0};  ///< full horizontal field of view, rad
};

/// Clears in *frontier every cell that was covered from one of the views (x, y, yaw; the
/// vehicle's poses where it reached its goals):
/// within [min_range, max_range] of it, inside the field of view about its yaw and in sight past
/// no known occupied cell (InSight with kOccupiedBandP: the camera looked through the unknown
/// cells on the way, and any it could resolve are resolved). A frontier cell still unknown after
/// the vehicle stood there facing it is one that the sensors cannot resolve (e.g. under
/// furniture, a strip along a wall seen only at grazing angles), so it stops being a goal.
/// Returns how many cells it cleared.
int ClearCoveredFrontiers(const GridMap2D& band, const std::vector<Eigen::Vector3d>& views,
                          const FrontierView& view, std::vector<bool>* frontier);

/// The heading (rad, in (-pi, pi]) from `position_m` that covers the most frontier cells (as in
/// ClearCoveredFrontiers), over `bins` evenly spaced headings; the count in *covered. Ties go
/// to the lower bin.
[[nodiscard]] double BestFrontierHeading(const GridMap2D& band, const std::vector<bool>& frontier,
                                         const Eigen::Vector2d& position_m,
                                         const FrontierView& view, double free_threshold, int bins,
                                         int* covered);

}  // namespace kestrel

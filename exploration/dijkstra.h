#pragma once
/// @file
/// Shortest paths on the collision map C (docs/algorithms.md §8.2): Dijkstra, 8-connected, step
/// cost the Euclidean distance between cell centres (alpha_C or sqrt(2) alpha_C), over the
/// traversable cells only; a diagonal step is allowed only when both orthogonal neighbours it
/// passes are traversable (no corner cutting). The start cell is always usable (the vehicle is
/// in it), whether or not it is traversable.

#include <vector>

#include "exploration/grid_map_2d.h"

namespace kestrel {

/// Result of a search: d_cell (m) and the back-pointer of every cell.
struct DistanceField {
  int width{0};                    ///< cells along x
  int height{0};                   ///< cells along y
  int start{-1};                   ///< linear index of the start cell
  std::vector<double> distance_m;  ///< d_cell, m; +inf where unreachable
  std::vector<int> parent;         ///< previous cell on a shortest path; -1 at start/unreached

  /// Whether a cell was reached.
  [[nodiscard]] bool Reachable(int index) const;
  /// The cells from the start to `goal` (inclusive both), empty if unreachable.
  [[nodiscard]] std::vector<int> PathTo(int goal) const;
  /// Largest finite d_cell, m (0 if only the start is reachable).
  [[nodiscard]] double MaxDistance() const;
};

/// Dijkstra from `start` over cells with traversable[i] (size width * height, x fastest).
/// Ties between equal distances are broken by cell index (deterministic).
/// @param step_weight  empty (the paper's Euclidean step cost), or one weight >= 1 per cell: a
///     step between cells i and j then costs its length times (w_i + w_j) / 2, and d_cell is
///     that weighted length (the fine modes' clearance preference, docs/exploration.md,
///     "Traversability").
/// @throws std::invalid_argument on inconsistent sizes, a start outside the grid or a weight
///     below 1 or not finite.
[[nodiscard]] DistanceField ComputeDistanceField(int width, int height,
                                                 const std::vector<bool>& traversable,
                                                 const Cell2& start, double cell_size_m,
                                                 const std::vector<double>& step_weight = {});

/// traversable[i] = P(C_i) <= collision_threshold (eq. 13).
[[nodiscard]] std::vector<bool> TraversableCells(const GridMap2D& collision,
                                                 double collision_threshold);

}  // namespace kestrel

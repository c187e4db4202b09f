#pragma once
/// @file
/// 3D ray traversal (ALGORITHMS.md section 2): Amanatides & Woo (1987) DDA from the sensor
/// origin o along unit direction u for a length L (normally z_max). Lists ALL cells the segment
/// [o, o + L u] passes through, in order of increasing distance, each with d_k, the distance
/// from o to the midpoint of the segment's chord through the cell: d_k = (t_entry + t_exit)/2,
/// chords clipped to [0, L].
///
/// Conventions (the tests' slab oracle uses the same ones):
///  - Cells are half-open, [B(i), B(i+1)) with B(i) = origin + i*alpha (GridGeometry::Boundary).
///  - The parameter at which the ray crosses boundary B is t = (B - o_axis) * (1 / u_axis), with
///    1/u computed once per ray (no accumulated steps), so every crossing is exact to a few
///    roundings and the same expression everywhere.
///  - A cell is listed iff its chord has positive length. A ray passing exactly through an edge or
///    corner steps all tied axes at once, so cells touched only at a point or an edge (zero-length
///    chords) are never listed; a ray starting on a boundary and pointing away from its cell does
///    not list that cell; a ray lying in a grid plane belongs to the cell on the upper side.
///  - Direction components below 1e-300 in magnitude are treated as 0.
///  - Cells outside the grid's bounds end the ray; an origin outside the bounds gives no cells.

#include <Eigen/Core>
#include <vector>

#include "mapping/grid.h"

namespace kestrel {

/// Caller-owned scratch for one ray: the cells crossed and their d_k. Sized once, reused for
/// every ray, so that casting allocates nothing.
struct RayCells {
  /// Scratch for rays of length up to `max_length_m` on a lattice of edge `resolution_m`.
  /// @throws std::invalid_argument unless both are positive and finite.
  RayCells(double max_length_m, double resolution_m);

  /// Upper bound on the cells a segment of length `length_m` crosses: sqrt(3)*L/alpha + 4.
  [[nodiscard]] static int CapacityFor(double length_m, double resolution_m);

  std::vector<CellIndex> cells;    ///< r_1 .. r_n, in order of increasing distance
  std::vector<double> distance_m;  ///< d_k, m, distance from o to the chord midpoint
  /// a_k per cell when has_likelihood: forward-model values computed off the map (on the
  /// traversal thread) by OccupancyUpdater::PrecomputeRay; Cast clears has_likelihood.
  std::vector<double> likelihood;
  int size{0};                 ///< n_r, the number of valid entries
  bool left_bounds{false};     ///< whether the ray ended at the grid bounds before its length
  bool has_likelihood{false};  ///< whether likelihood[0 .. size) is filled
  double max_length_m;         ///< longest ray this scratch holds, m
};

/// Casts rays through a lattice (fixed or unbounded). Reads no map: traversal can run apart from
/// (and ahead of) the updates.
class RayCaster {
 public:
  /// A caster over `geometry` (copied).
  explicit RayCaster(const GridGeometry& geometry) : geometry_(geometry) {}

  /// Fills `out` with the cells of the segment from origin_W along direction_W (unit) for
  /// length_m, as described in the file comment. Returns out->size.
  /// Preconditions (checked, cheap): origin finite, |direction| = 1 within 1e-6,
  /// 0 <= length_m <= out->max_length_m.
  /// @throws std::invalid_argument when a precondition fails.
  int Cast(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W, double length_m,
           RayCells* out) const;

  /// The lattice.
  [[nodiscard]] const GridGeometry& geometry() const { return geometry_; }

 private:
  GridGeometry geometry_;
};

}  // namespace kestrel

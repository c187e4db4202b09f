#pragma once
/// @file
/// 3D ray traversal (docs/algorithms.md §2.1): Amanatides & Woo (1987) DDA from the sensor
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
///    The ray is clipped once to the parameter at which it leaves the bounds' box, computed with
///    the same expression as the crossing of the last in-bounds cell's boundary, so that no step
///    checks the bounds.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "mapping/grid.h"
#include "mapping/lanes.h"

namespace kestrel {

namespace detail {
struct RayWalk;  // one ray's traversal state (kernels/ray_walk.h)
}  // namespace detail
namespace kernels {
struct Kernels;  // one instruction set's kernels (kernels/kernels.h)
}  // namespace kernels

/// Caller-owned scratch for one ray: the cells crossed and their d_k. Sized once, reused for
/// every ray, so that casting allocates nothing.
struct RayCells {
  /// Scratch for rays of length up to `max_length_m` on a lattice of edge `resolution_m`.
  /// @throws std::invalid_argument unless both are positive and finite.
  RayCells(double max_length_m, double resolution_m);

  /// Upper bound on the cells a segment of length `length_m` crosses, with margin for rounding:
  /// ceil(sqrt(3) (1 + 1e-5) L/alpha) + 8 (ray_caster.cc, RayCaster::Cast).
  [[nodiscard]] static int CapacityFor(double length_m, double resolution_m);

  std::vector<CellIndex> cells;    ///< r_1 .. r_n, in order of increasing distance
  std::vector<double> distance_m;  ///< d_k, m, distance from o to the chord midpoint
  /// When has_linear_index: the cell's index in a DenseGrid over the caster's (bounded) lattice,
  /// x + nx (y + ny z) (DenseGrid::LinearIndexOf), kept by the caster with one addition per step;
  /// x, y, z and nx, ny count from the lattice's lower bound (0 for a fixed map).
  /// 32 bits: lattices of 2^31 cells or more get no linear index.
  std::vector<int32_t> linear_index;
  int size{0};                   ///< n_r, the number of valid entries
  bool left_bounds{false};       ///< whether the ray ended at the grid bounds before its length
  bool has_linear_index{false};  ///< whether linear_index[0 .. size) is filled (bounded lattice)
  double max_length_m;           ///< longest ray this scratch holds, m
  /// The in-bounds cell of the last origin cast with this scratch on the lattice
  /// last_origin_lattice (rays of one scan share their origin, and GridGeometry::CellOf is the
  /// costliest part of a ray's set-up). NaN until the first cast.
  Eigen::Vector3d last_origin_W{
      Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())};
  CellIndex last_origin_cell;        ///< cell of last_origin_W
  GridGeometry last_origin_lattice;  ///< lattice of last_origin_cell
};

/// One ray to cast: from origin_W along unit direction_W for length_m.
struct RaySegment {
  Eigen::Vector3d origin_W{Eigen::Vector3d::Zero()};      ///< sensor origin o, m, W
  Eigen::Vector3d direction_W{Eigen::Vector3d::UnitX()};  ///< unit direction u, W
  double length_m{0.0};                                   ///< L, m
};

/// Caller-owned scratch for up to lanes::kLanes rays cast together (RayCaster::CastBatch) on a
/// bounded lattice: the k-th cell of lane (ray) l is at [k * kLanes + l] of every array, so eight
/// rays step in one vector register. Holds what RayCells holds with has_linear_index and
/// without cells, and optionally a_k. Sized once. The one ray type of the scan integrator
/// (mapping/scan_integrator.h): a single ray is a batch of one lane.
struct RayBatch {
  /// Scratch for rays of length up to `max_length_m` on a lattice of edge `resolution_m`.
  /// @throws std::invalid_argument unless both are positive and finite.
  RayBatch(double max_length_m, double resolution_m);

  /// Cells per lane this scratch holds (RayCells::CapacityFor).
  [[nodiscard]] int capacity() const { return capacity_; }
  /// Index of lane l's k-th cell in the arrays.
  [[nodiscard]] static size_t At(int k, int lane) {
    return static_cast<size_t>(k) * lanes::kLanes + static_cast<size_t>(lane);
  }

  std::vector<double> distance_m;     ///< d_k per lane, m (ray_caster.h)
  std::vector<int32_t> linear_index;  ///< x + nx (y + ny z) per lane (RayCells::linear_index)
  /// a_k per lane when has_likelihood (OccupancyUpdater::PrecomputeBatch); CastBatch clears it.
  std::vector<double> likelihood;
  bool has_likelihood{false};  ///< whether likelihood holds a_k for the rays of the last cast
  int count{0};                ///< lanes in use, the rays of the last CastBatch
  /// The lattice and bounds of the last CastBatch: linear indices count from lattice.lower().
  GridGeometry lattice;
  int size[lanes::kLanes]{};          ///< n_r per lane
  bool left_bounds[lanes::kLanes]{};  ///< per lane, as RayCells::left_bounds
  int longest{0};                     ///< max of size[]: the rows of the arrays in use
  double max_length_m;                ///< longest ray this scratch holds, m
  /// Cell of the last origin cast on the lattice last_origin_lattice (as in RayCells).
  Eigen::Vector3d last_origin_W{
      Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())};
  CellIndex last_origin_cell;        ///< cell of last_origin_W
  GridGeometry last_origin_lattice;  ///< lattice of last_origin_cell

 private:
  int capacity_;
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
  /// Same, and for a bounded lattice (of fewer than 2^31 cells) also fills out->linear_index
  /// (has_linear_index).
  int CastWithLinearIndex(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W,
                          double length_m, RayCells* out) const;

  /// Casts rays[0 .. count) (count <= lanes::kLanes) together, eight lanes stepping in one
  /// vector register: lane l gets exactly the d_k, linear indices and left_bounds that
  /// CastWithLinearIndex gives rays[l], bit for bit, with every instruction set's `kernels`
  /// (kernels/kernels.h). Precondition: LinearIndexable(); checks as Cast.
  /// @throws std::invalid_argument when a precondition fails.
  void CastBatch(const RaySegment* rays, int count, RayBatch* out,
                 const kernels::Kernels& kernels) const;

  /// The lattice.
  [[nodiscard]] const GridGeometry& geometry() const { return geometry_; }
  /// Whether this lattice gets linear indices (bounded, fewer than 2^31 cells).
  [[nodiscard]] bool LinearIndexable() const;

 private:
  // Checks the inputs (as Cast) and sets up the walk of one ray: its first cell (through the
  // origin cache), per-axis steps and crossings, the clip at the bounds, the linear index, and
  // the capacity check. Returns false when the origin lies outside the bounds.
  bool StartWalk(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
                 double max_length_m, int capacity, Eigen::Vector3d* last_origin_W,
                 CellIndex* last_origin_cell, GridGeometry* last_origin_lattice,
                 detail::RayWalk* walk) const;
  template <bool kLinear>
  int CastImpl(const Eigen::Vector3d& o, const Eigen::Vector3d& u, double length_m,
               RayCells* out) const;

  GridGeometry geometry_;
};

}  // namespace kestrel

#pragma once
/// @file
/// 2D ray traversal in a GridMap2D (Amanatides & Woo 1987), the planar counterpart of
/// mapping/ray_caster.h with the same conventions (docs/algorithms.md §2.3): half-open cells
/// [B(i), B(i+1)) with B(i) = origin + i*alpha; crossing parameters t = (B - o)/u as one
/// correctly rounded division; a cell is listed iff its chord has positive length; tied axes step
/// together (a ray through a corner does not list the cells it only touches); a ray starting on a
/// boundary and pointing away from its cell does not list that cell; cells outside the grid end
/// the ray. Each listed cell carries its chord [entry, exit] (clipped to [0, L]) and d_k, the
/// chord midpoint (entry + exit)/2, used as the distance in the sensor model.

#include <Eigen/Core>
#include <vector>

#include "exploration/grid_map_2d.h"

namespace kestrel {

/// Caller-owned result of a 2D cast, reused across rays (no allocation once sized).
struct Ray2D {
  std::vector<int> index;          ///< linear cell indices (GridMap2D::IndexOf), in ray order
  std::vector<double> entry_m;     ///< chord start, m from the origin
  std::vector<double> exit_m;      ///< chord end, m from the origin
  std::vector<double> distance_m;  ///< d_k = (entry + exit)/2, m
  int size{0};                     ///< n_r
  bool left_bounds{false};         ///< whether the ray ended at the grid bounds before L

  /// Empties the ray (keeps capacity).
  void Clear() {
    index.clear();
    entry_m.clear();
    exit_m.clear();
    distance_m.clear();
    size = 0;
    left_bounds = false;
  }
};

/// Casts the segment [o, o + L u] through `grid` into *out (file comment for the conventions).
/// Preconditions (checked): o finite, |u| = 1 within 1e-6, L >= 0 finite, out != nullptr.
/// An origin outside the grid gives no cells. @throws std::invalid_argument.
int CastRay2D(const GridMap2D& grid, const Eigen::Vector2d& origin_m,
              const Eigen::Vector2d& direction, double length_m, Ray2D* out);

}  // namespace kestrel

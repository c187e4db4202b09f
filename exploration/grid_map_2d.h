#pragma once
/// @file
/// A 2D grid in the plane z = height_m of the world frame W (x east, y north, z up): the
/// explorer's collision map C, entropy map E and combined map B (docs/algorithms.md §7). Cell
/// (ix, iy) spans [origin + ix*alpha, origin + (ix+1)*alpha) x [..) (half-open, aligned to the
/// 3D map's lower limit, as in docs/algorithms.md §1.1). Values are x fastest, like
/// kestrel::grid_map_t.

#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <vector>

namespace kestrel {

/// Integer index of a 2D cell.
struct Cell2 {
  int x{0};  ///< index along world x
  int y{0};  ///< index along world y
  [[nodiscard]] friend bool operator==(const Cell2& a, const Cell2& b) {
    return a.x == b.x && a.y == b.y;
  }
  [[nodiscard]] friend bool operator!=(const Cell2& a, const Cell2& b) { return !(a == b); }
};

/// A dense 2D grid of doubles (occupancy probabilities unless said otherwise).
struct GridMap2D {
  Eigen::Vector2d origin_m{Eigen::Vector2d::Zero()};  ///< lower corner of cell (0, 0), m, W
  double resolution_m{1.0};                           ///< cell edge, m
  double height_m{0.0};                               ///< the plane's height h, m, W
  int width{0};                                       ///< cells along x
  int height{0};                                      ///< cells along y
  std::vector<double> values;                         ///< width * height values, x fastest

  /// A grid of width x height cells, every value `fill`.
  static GridMap2D Filled(const Eigen::Vector2d& origin_m, double resolution_m, double height_m,
                          int width, int height, double fill) {
    GridMap2D g;
    g.origin_m = origin_m;
    g.resolution_m = resolution_m;
    g.height_m = height_m;
    g.width = width;
    g.height = height;
    g.values.assign(static_cast<size_t>(width) * static_cast<size_t>(height), fill);
    return g;
  }
  /// Number of cells.
  [[nodiscard]] int size() const { return width * height; }
  /// Whether (x, y) is a cell of the grid.
  [[nodiscard]] bool Contains(int x, int y) const {
    return x >= 0 && y >= 0 && x < width && y < height;
  }
  /// Whether `c` is a cell of the grid.
  [[nodiscard]] bool Contains(const Cell2& c) const { return Contains(c.x, c.y); }
  /// Linear index of an in-bounds cell.
  [[nodiscard]] int IndexOf(int x, int y) const { return x + width * y; }
  /// Linear index of an in-bounds cell.
  [[nodiscard]] int IndexOf(const Cell2& c) const { return IndexOf(c.x, c.y); }
  /// Cell of a linear index.
  [[nodiscard]] Cell2 CellAt(int index) const { return {index % width, index / width}; }
  /// Value of an in-bounds cell.
  [[nodiscard]] double at(int x, int y) const { return values[static_cast<size_t>(IndexOf(x, y))]; }
  /// Value of an in-bounds cell.
  [[nodiscard]] double at(const Cell2& c) const { return at(c.x, c.y); }
  /// Mutable value of an in-bounds cell.
  [[nodiscard]] double& at(int x, int y) { return values[static_cast<size_t>(IndexOf(x, y))]; }
  /// Centre of a cell (x, y), m, W.
  [[nodiscard]] Eigen::Vector2d CenterOf(const Cell2& c) const {
    return {origin_m.x() + (c.x + 0.5) * resolution_m, origin_m.y() + (c.y + 0.5) * resolution_m};
  }
  /// The cell containing point (x, y) of W, or nullopt outside the grid (or not finite).
  [[nodiscard]] std::optional<Cell2> CellOf(const Eigen::Vector2d& p_m) const {
    if (!std::isfinite(p_m.x()) || !std::isfinite(p_m.y())) return std::nullopt;
    const Cell2 c{static_cast<int>(std::floor((p_m.x() - origin_m.x()) / resolution_m)),
                  static_cast<int>(std::floor((p_m.y() - origin_m.y()) / resolution_m))};
    if (!Contains(c)) return std::nullopt;
    return c;
  }
};

}  // namespace kestrel

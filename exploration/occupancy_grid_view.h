#pragma once
/// @file
/// The map every exploration mode reads: a view of a 3D occupancy grid's probabilities
/// (docs/algorithms.md §1.1), whether it is the mapper's own grid or the explorer's copy.

#include <Eigen/Core>
#include <cstddef>

namespace kestrel {

class DenseGrid;

/// Minimal read interface to a 3D occupancy grid (docs/algorithms.md §1.1): `dims` cells per
/// axis, cell (i, j, k) spans origin + [i, i+1) * alpha etc., probability values x fastest then
/// y then z (the layout of mapping's DenseGrid). Not owning.
struct OccupancyGridView {
  Eigen::Vector3i dims{Eigen::Vector3i::Zero()};      ///< cells per axis
  Eigen::Vector3d origin_m{Eigen::Vector3d::Zero()};  ///< lower corner of cell (0,0,0), m, W
  double resolution_m{1.0};                           ///< cell edge alpha, m
  const float* probability{nullptr};                  ///< dims.prod() occupancy probabilities

  /// P(m_(i,j,k)) of an in-bounds cell.
  [[nodiscard]] double At(int i, int j, int k) const {
    return static_cast<double>(
        probability[static_cast<size_t>(i) +
                    static_cast<size_t>(dims.x()) *
                        (static_cast<size_t>(j) +
                         static_cast<size_t>(dims.y()) * static_cast<size_t>(k))]);
  }
  /// @throws std::invalid_argument unless dims > 0, resolution > 0, origin finite, data set.
  void Validate() const;
};

/// A view of mapping's dense grid whose cells hold probabilities (the exact map). The grid must
/// outlive the view.
[[nodiscard]] OccupancyGridView ViewOf(const DenseGrid& grid);

}  // namespace kestrel

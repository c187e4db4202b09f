#pragma once
/// @file
/// Map quality against the simulator's ground truth (docs/algorithms.md §12) on the mapper's
/// lattice: the world voxelised on it, and the observable cells from a dense sweep of
/// collision-free poses at the exploration height.

#include <functional>
#include <vector>

#include "mapping/grid.h"
#include "mapping/map_quality.h"
#include "sim/ground_truth.h"
#include "sim/world.h"
#include "sim/world_ray_caster.h"

namespace kestrel {

/// The scorer's grid for a fixed map's lattice (its lower corner, edge and cell counts).
[[nodiscard]] inline GridSpec GridSpecOf(const GridGeometry& geometry) {
  return GridSpec{geometry.origin_m(), geometry.resolution_m(),
                  Eigen::Vector3i(geometry.upper().x, geometry.upper().y, geometry.upper().z)};
}

class MapScorer {
 public:
  /// Ground truth of `world` on `grid`; rays of the sweep reach max_range_m within +-vfov/2 and
  /// return from up to the depth camera's reported depth `camera_depth_range_m` (SensorSweep). A
  /// ray that meets nothing observes only in the LIDAR's plane unless `camera_no_return_informs`
  /// (the depth camera model's no_return_informs: docs/algorithms.md §3.4, §12.1).
  MapScorer(const World& world, const WorldRayCaster& caster, const GridSpec& grid,
            double max_range_m, double vertical_fov_rad, bool camera_no_return_informs = false,
            double camera_depth_range_m = 8.0);

  /// P of every cell of the grid, in its linear order (as truth() and observable()).
  [[nodiscard]] std::vector<double> Probabilities(
      const std::function<double(const CellIndex&)>& probability) const;
  /// Scores a map given the probability of each cell; p_init is the map's prior.
  [[nodiscard]] MapQuality Score(const std::function<double(const CellIndex&)>& probability,
                                 double p_init) const;
  [[nodiscard]] const GridSpec& grid() const { return grid_; }
  /// The truth (1: occupied) and the observable mask, per cell in the grid's linear order.
  [[nodiscard]] const std::vector<uint8_t>& truth() const { return truth_; }
  [[nodiscard]] const std::vector<uint8_t>& observable() const { return observable_; }

  /// Where the observable cells that are not known lie: counts per column bin of bin_m x bin_m
  /// (row-major from the grid's minimum corner, x fastest), per grid layer, and split into
  /// cells never updated (P == p_init) and cells updated but still between P_init/2 and 0.5.
  struct UnknownCells {
    int bins_x{0}, bins_y{0};
    std::vector<size_t> per_bin;    ///< bins_x * bins_y
    std::vector<size_t> per_layer;  ///< grid.dims.z()
    size_t never_updated{0};
    size_t updated{0};
  };
  [[nodiscard]] UnknownCells Unknown(const std::function<double(const CellIndex&)>& probability,
                                     double p_init, double bin_m) const;

 private:
  GridSpec grid_;
  std::vector<uint8_t> truth_;
  std::vector<uint8_t> observable_;
};

}  // namespace kestrel

#include "exploration/occupancy_grid_view.h"

#include <cmath>

#include "common/check.h"
#include "mapping/grid.h"

namespace kestrel {

void OccupancyGridView::Validate() const {
  KESTREL_THROW_UNLESS(dims.minCoeff() > 0,
                       "OccupancyGridView dims = " << dims.transpose() << ", accepted > 0");
  KESTREL_THROW_UNLESS(
      std::isfinite(resolution_m) && resolution_m > 0.0,
      "OccupancyGridView resolution_m = " << resolution_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(origin_m.allFinite(), "OccupancyGridView origin_m not finite");
  KESTREL_THROW_UNLESS(probability != nullptr, "OccupancyGridView probability is null");
}

OccupancyGridView ViewOf(const DenseGrid& grid) {
  OccupancyGridView view;
  view.dims = Eigen::Vector3i(grid.dims().x, grid.dims().y, grid.dims().z);
  view.origin_m = grid.geometry().origin_m();
  view.resolution_m = grid.geometry().resolution_m();
  view.probability = grid.values().data();
  return view;
}

}  // namespace kestrel

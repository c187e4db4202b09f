// The scalar walk of a batch's lanes (kernels.h, WalkLanesFn; RayCaster::CastBatch): each lane
// walked alone, into the batch's layout.
#include <cstdint>

#include "mapping/kernels/kernels.h"
#include "mapping/kernels/ray_walk.h"
#include "mapping/lanes.h"
#include "mapping/ray_caster.h"

namespace kestrel::kernels {

using detail::RayWalk;
using detail::WalkRay;

void WalkLanesScalar(const RaySegment* rays, int count, const bool* started, RayWalk* walks,
                     const Eigen::Vector3d& origin, double resolution, double* distance,
                     int32_t* linear_out, int32_t* size) {
  using lanes::kLanes;
  for (int l = 0; l < count; ++l) {
    if (!started[l]) continue;
    RayWalk w = walks[l];
    size[l] = WalkRay<true, false>(&w, rays[l].origin_W, origin, resolution, kLanes, distance + l,
                                   linear_out + l, nullptr)
                  .cells;
  }
}

}  // namespace kestrel::kernels

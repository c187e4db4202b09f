// Peak memory of Kestrel's maps at 0.075 m: the paper's dense map (8 x 12 x 1.65 m) and a
// growing map of 50 x 50 x 5 m with every block touched. Run one map per process:
//   mapping_memory dense | growing
// Prints the map's own byte count and the process's peak resident set (getrusage ru_maxrss)
// before and after building it.
#include <sys/resource.h>

#include <cstdio>
#include <cstring>

#include "mapping/occupancy_map.h"

namespace {
long PeakRssKb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}
}  // namespace

int main(int argc, char** argv) {
  using namespace kestrel;
  if (argc != 2 || (std::strcmp(argv[1], "dense") != 0 && std::strcmp(argv[1], "growing") != 0)) {
    std::fprintf(stderr, "usage: mapping_memory dense|growing\n");
    return 2;
  }
  const long before_kb = PeakRssKb();
  if (std::strcmp(argv[1], "dense") == 0) {
    auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
    std::printf(
        "dense 8 x 12 x 1.65 m @ 0.075 m: %zu cells, map %.2f MB, peak RSS %.2f MB "
        "(before %.2f MB)\n",
        map->grid().size(), map->grid().memory_bytes() / 1e6, PeakRssKb() / 1e3, before_kb / 1e3);
  } else {
    MapLimits limits;
    limits.min_m = Eigen::Vector3d(-25.0, -25.0, -0.15);
    limits.max_m = Eigen::Vector3d(25.0, 25.0, 4.85);
    auto map = MakeExactGrowingMap(limits, OccupancyLimits{}, 4.0);
    GrowingGrid& grid = map->mutable_grid();
    const GridGeometry g = GridGeometry::Fixed(limits);
    const int edge = GrowingGrid::kBlockEdge;
    for (int z = 0; z < g.upper().z; z += edge)
      for (int y = 0; y < g.upper().y; y += edge)
        for (int x = 0; x < g.upper().x; x += edge) grid.FindOrCreateBlock(CellIndex{x, y, z});
    std::printf(
        "growing 50 x 50 x 5 m @ 0.075 m, all touched: %d x %d x %d cells, %zu blocks, "
        "map %.2f MB, peak RSS %.2f MB (before %.2f MB)\n",
        g.upper().x, g.upper().y, g.upper().z, grid.block_count(), grid.memory_bytes() / 1e6,
        PeakRssKb() / 1e3, before_kb / 1e3);
  }
  return 0;
}

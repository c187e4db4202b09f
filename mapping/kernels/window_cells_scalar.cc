// The scalar resolution of a GrowingGrid's cells in a cast window (kernels.h,
// ResolveWindowCellsFn; OccupancyMap<GrowingGrid>::UpdateRays).
#include <cstdint>

#include "mapping/kernels/kernels.h"
#include "mapping/lanes.h"

namespace kestrel::kernels {

bool ResolveWindowCellsScalar(const int32_t* linear, const int* size, int rows, int shift,
                              float* const* blocks, float** cells, uint32_t* slot_cells) {
  using lanes::kLanes;
  const int32_t mask = (int32_t{1} << shift) - 1;
  const int b = shift - 3;  // log2 of the window's blocks per axis
  for (int l = 0; l < kLanes; ++l) {
    const int n = size[l] < rows ? size[l] : rows;
    for (int k = 0; k < n; ++k) {
      const ptrdiff_t at = static_cast<ptrdiff_t>(k) * kLanes + l;
      const int32_t cell = linear[at];
      const int32_t x = cell & mask, y = (cell >> shift) & mask, z = cell >> (2 * shift);
      const int32_t slot = (x >> 3) | ((y >> 3) << b) | ((z >> 3) << (2 * b));
      float* const block = blocks[slot];
      if (block == nullptr) return false;
      const int32_t offset = (x & 7) | ((y & 7) << 3) | ((z & 7) << 6);
      cells[at] = block + offset;
      slot_cells[at] = static_cast<uint32_t>((slot << 9) | offset);
    }
  }
  return true;
}

}  // namespace kestrel::kernels

// The vector resolution of a GrowingGrid's cells in a cast window (kernels.h,
// ResolveWindowCellsFn; OccupancyMap<GrowingGrid>::UpdateRays), one source for every Highway
// target (simd_kernels.cc compiles it once per target): a row of a batch, Lanes(D8) lanes at a
// time, the block addresses gathered from the window's table where the target has gather
// instructions (AVX2, AVX3, SVE) and looked up lane by lane elsewhere.
// NOLINT(llvm-header-guard)
#if defined(KESTREL_MAPPING_KERNELS_WINDOW_CELLS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef KESTREL_MAPPING_KERNELS_WINDOW_CELLS_INL_H_
#undef KESTREL_MAPPING_KERNELS_WINDOW_CELLS_INL_H_
#else
#define KESTREL_MAPPING_KERNELS_WINDOW_CELLS_INL_H_
#endif

#include <hwy/highway.h>

#include <cstddef>
#include <cstdint>

#include "mapping/kernels/simd-inl.h"
#include "mapping/lanes.h"

HWY_BEFORE_NAMESPACE();
namespace kestrel::kernels::HWY_NAMESPACE {

// kernels::ResolveWindowCellsFn.
bool ResolveWindowCells(const int32_t* linear, const int* size, int rows, int shift,
                        float* const* blocks, float** cells, uint32_t* slot_cells) {
  const ZeroUpperOnReturn zero_upper;
  static_assert(sizeof(float*) == sizeof(int64_t), "64-bit addresses");
  const hn::Rebind<int32_t, D8> di;
  const size_t n = hn::Lanes(di);
  const auto mask = hn::Set(di, (int32_t{1} << shift) - 1);
  const auto seven = hn::Set(di, 7);
  const int b = shift - 3;  // log2 of the window's blocks per axis
  bool missing = false;
  for (size_t first = 0; first < static_cast<size_t>(lanes::kLanes); first += n) {
    const auto sizes = hn::LoadU(di, size + first);
    for (int k = 0; k < rows; ++k) {
      const auto live = hn::Lt(hn::Set(di, k), sizes);  // k < size[l]
      const ptrdiff_t at =
          static_cast<ptrdiff_t>(k) * lanes::kLanes + static_cast<ptrdiff_t>(first);
      const auto cell = hn::IfThenElseZero(live, hn::LoadU(di, linear + at));
      const auto x = hn::And(cell, mask);
      const auto y = hn::And(hn::ShiftRightSame(cell, shift), mask);
      const auto z = hn::ShiftRightSame(cell, 2 * shift);
      const auto slot =
          hn::Or(hn::ShiftRight<3>(x), hn::Or(hn::ShiftLeftSame(hn::ShiftRight<3>(y), b),
                                              hn::ShiftLeftSame(hn::ShiftRight<3>(z), 2 * b)));
      const auto offset = hn::Or(hn::And(x, seven), hn::Or(hn::ShiftLeft<3>(hn::And(y, seven)),
                                                           hn::ShiftLeft<6>(hn::And(z, seven))));
      hn::StoreU(hn::BitCast(hn::Rebind<uint32_t, D8>(), hn::Or(hn::ShiftLeft<9>(slot), offset)),
                 hn::Rebind<uint32_t, D8>(), slot_cells + at);
#if HWY_HAVE_SCALABLE || (HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX2)
      const hn::Rebind<int64_t, D8> dl;
      // A gather of the block addresses (dead lanes read blocks[0] and are not checked), then
      // the address of float `offset` of the block: block + 4 offset bytes.
      const auto block =
          hn::GatherIndex(dl, reinterpret_cast<const int64_t*>(blocks), hn::PromoteTo(dl, slot));
      const auto live_block = hn::Lt(hn::Set(dl, int64_t{k}), hn::PromoteTo(dl, sizes));
      missing |= !hn::AllFalse(dl, hn::And(live_block, hn::Eq(block, hn::Zero(dl))));
      const auto address = hn::Add(block, hn::ShiftLeft<2>(hn::PromoteTo(dl, offset)));
      hn::StoreU(address, dl, reinterpret_cast<int64_t*>(cells + at));
#else
      alignas(64) int32_t slots[lanes::kLanes], offsets[lanes::kLanes], lives[lanes::kLanes];
      hn::StoreU(slot, di, slots);
      hn::StoreU(offset, di, offsets);
      hn::StoreU(hn::VecFromMask(di, live), di, lives);
      for (size_t j = 0; j < n; ++j) {
        if (lives[j] == 0) continue;
        float* const block = blocks[slots[j]];
        missing |= block == nullptr;
        if (block != nullptr) cells[static_cast<size_t>(at) + j] = block + offsets[j];
      }
#endif
    }
  }
  return !missing;
}

}  // namespace kestrel::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // KESTREL_MAPPING_KERNELS_WINDOW_CELLS_INL_H_

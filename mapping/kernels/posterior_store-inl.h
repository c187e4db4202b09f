// The vector posterior stores of the exact update (kernels.h, StorePosteriorsFn and
// StorePosteriorsAtFn; ExactBayesUpdater::UpdateBatchLane), one source for every Highway target
// (simd_kernels.cc compiles it once per target).
// NOLINT(llvm-header-guard)
#if defined(KESTREL_MAPPING_KERNELS_POSTERIOR_STORE_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef KESTREL_MAPPING_KERNELS_POSTERIOR_STORE_INL_H_
#undef KESTREL_MAPPING_KERNELS_POSTERIOR_STORE_INL_H_
#else
#define KESTREL_MAPPING_KERNELS_POSTERIOR_STORE_INL_H_
#endif

#include <hwy/highway.h>

#include <cstddef>
#include <cstdint>

#include "mapping/kernels/posterior_store.h"
#include "mapping/kernels/simd-inl.h"
#include "mapping/lanes.h"

HWY_BEFORE_NAMESPACE();
namespace kestrel::kernels::HWY_NAMESPACE {

// The write step of ExactBayesUpdater's update for n cells, Lanes(D8) at a time: the posterior
// scale * P_i (scale[i] per cell, or scale[0]) with P_i = priors[i] as a double, clamped
// (ClampProbability as min then max with the scalar code's operand order, so ties and values
// agree), converted to float and handed to store(i, floats) for cells i .. i + Lanes(D8) - 1;
// lists the cells whose stored value changed, first + i ascending, in changed[0 .. returned
// count) (compared bit for bit with priors[i]). The last n % Lanes(D8) cells go through the
// scalar code (StoreCells) with `cell_at`.
template <bool kPerCell, class Store, class CellAt>
HWY_INLINE int StoreRows(const double* scale, const float* priors, int first, int n, double p_min,
                         int* changed, const Store& store, const CellAt& cell_at) {
  const D8 d;
  const hn::Rebind<float, D8> df;
  const hn::Rebind<int32_t, D8> di;
  const int lanes_in_d = static_cast<int>(hn::Lanes(d));
  const auto lower = hn::Set(d, p_min);
  const auto upper = hn::Set(d, 1.0 - p_min);
  const auto run_scale = hn::Set(d, scale[0]);
#if (HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3) || HWY_HAVE_SCALABLE
  auto k = hn::Iota(di, first);  // first + i + lane
  const auto step = hn::Set(di, lanes_in_d);
#endif
  int m = 0;
  int i = 0;
  for (; i + lanes_in_d <= n; i += lanes_in_d) {
    const auto prior = hn::LoadU(df, priors + i);
    auto scale_i = run_scale;
    if constexpr (kPerCell) scale_i = hn::LoadU(d, scale + i);
    const auto p = hn::Mul(scale_i, hn::PromoteTo(d, prior));
    // upper < p ? upper : p, then below_upper < p_min ? p_min : below_upper.
    const auto stored = hn::DemoteTo(df, MaxLikeScalar(d, lower, MinLikeScalar(d, upper, p)));
    const auto differ = hn::Ne(hn::BitCast(di, stored), hn::BitCast(di, prior));
#if (HWY_ARCH_X86 && HWY_TARGET <= HWY_AVX3) || HWY_HAVE_SCALABLE
    // The changed cells' numbers packed in a register (one instruction here), then stored whole
    // (room: m + Lanes <= i + Lanes <= n); AVX-512's compress into memory costs far more on AMD
    // Zen 4.
    hn::StoreU(hn::Compress(k, differ), di, changed + m);
    m += static_cast<int>(hn::CountTrue(di, differ));
    k = hn::Add(k, step);
#else
    // Without a compress instruction (Highway's Compress builds its shuffle table on the stack
    // each time): the lanes whose bit is set, packed, from a table of the 16 masks of four lanes
    // (two-lane vectors use its first two columns), plus first + i, stored whole.
    static_assert(hn::MaxLanes(hn::Rebind<int32_t, D8>()) <= 4, "SSE4, NEON, AVX2");
    alignas(16) static constexpr int32_t kPacked[16][4] = {
        {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0},
        {1, 2, 0, 0}, {0, 1, 2, 0}, {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0},
        {2, 3, 0, 0}, {0, 2, 3, 0}, {1, 2, 3, 0}, {0, 1, 2, 3}};
    uint8_t bits[8] = {};
    hn::StoreMaskBits(di, differ, bits);
    hn::StoreU(hn::Add(hn::LoadU(di, kPacked[bits[0]]), hn::Set(di, first + i)), di, changed + m);
    m += static_cast<int>(hwy::PopCount(bits[0]));
#endif
    // Only where a value changed (most cells of a ray sit at the clamp and keep their value). A
    // ray never lists a cell twice, so the order of the stores does not matter.
    if (!hn::AllFalse(di, differ)) store(i, stored);
  }
  return StoreCells(scale, kPerCell, priors, first, i, n, p_min, cell_at, changed, m);
}

// kernels::StorePosteriorsFn: the floats stored at base[cells[i]] (a scatter).
int StorePosteriors(const double* scale, bool per_cell, const float* priors, const int32_t* cells,
                    int first, int n, double p_min, float* base, int* changed) {
  const ZeroUpperOnReturn zero_upper;
  const hn::Rebind<float, D8> df;
  const hn::Rebind<int32_t, D8> di;
  const auto store = [&](int i, hn::Vec<hn::Rebind<float, D8>> stored) {
    hn::ScatterIndex(stored, df, base, hn::LoadU(di, cells + i));
  };
  const auto cell_at = [base, cells](int i) -> float& { return base[cells[i]]; };
  return per_cell ? StoreRows<true>(scale, priors, first, n, p_min, changed, store, cell_at)
                  : StoreRows<false>(scale, priors, first, n, p_min, changed, store, cell_at);
}

// kernels::StorePosteriorsAtFn: the floats stored at *cells[i], one by one.
int StorePosteriorsAt(const double* scale, bool per_cell, const float* priors, float* const* cells,
                      int first, int n, double p_min, int* changed) {
  const ZeroUpperOnReturn zero_upper;
  const hn::Rebind<float, D8> df;
  const auto store = [&](int i, hn::Vec<hn::Rebind<float, D8>> stored) {
    alignas(64) float values[lanes::kLanes];
    hn::StoreU(stored, df, values);
    for (size_t j = 0; j < hn::Lanes(df); ++j) *cells[static_cast<size_t>(i) + j] = values[j];
  };
  const auto cell_at = [cells](int i) -> float& { return *cells[i]; };
  return per_cell ? StoreRows<true>(scale, priors, first, n, p_min, changed, store, cell_at)
                  : StoreRows<false>(scale, priors, first, n, p_min, changed, store, cell_at);
}

}  // namespace kestrel::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // KESTREL_MAPPING_KERNELS_POSTERIOR_STORE_INL_H_

// The vector forward model of a batch (kernels.h, FillLikelihoodsFn;
// SensorModel::FillLikelihoods), one source for every Highway target (simd_kernels.cc compiles
// it once per target).
// NOLINT(llvm-header-guard)
#if defined(KESTREL_MAPPING_KERNELS_LIKELIHOODS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef KESTREL_MAPPING_KERNELS_LIKELIHOODS_INL_H_
#undef KESTREL_MAPPING_KERNELS_LIKELIHOODS_INL_H_
#else
#define KESTREL_MAPPING_KERNELS_LIKELIHOODS_INL_H_
#endif

#include <hwy/highway.h>

#include <cstddef>
#include <cstdint>

#include "mapping/kernels/kernels.h"
#include "mapping/kernels/simd-inl.h"
#include "mapping/lanes.h"

HWY_BEFORE_NAMESPACE();
namespace kestrel::kernels::HWY_NAMESPACE {

// The four coefficients of four table rows (row[i] = table + 4 at[i]) as four vectors of four
// lanes: a 4 x 4 transpose of four 32-byte loads.
template <class D4, class V = hn::Vec<D4>>
HWY_INLINE void TransposeRows4(D4 d4, const double* table, const int32_t* at, V* c0, V* c1, V* c2,
                               V* c3) {
  const V r0 = hn::LoadU(d4, table + ptrdiff_t{4} * at[0]);
  const V r1 = hn::LoadU(d4, table + ptrdiff_t{4} * at[1]);
  const V r2 = hn::LoadU(d4, table + ptrdiff_t{4} * at[2]);
  const V r3 = hn::LoadU(d4, table + ptrdiff_t{4} * at[3]);
  const V t0 = hn::InterleaveLower(d4, r0, r1);  // [r0.c0 r1.c0 | r0.c2 r1.c2]
  const V t1 = hn::InterleaveUpper(d4, r0, r1);  // [r0.c1 r1.c1 | r0.c3 r1.c3]
  const V t2 = hn::InterleaveLower(d4, r2, r3);
  const V t3 = hn::InterleaveUpper(d4, r2, r3);
  *c0 = hn::ConcatLowerLower(d4, t2, t0);
  *c1 = hn::ConcatLowerLower(d4, t3, t1);
  *c2 = hn::ConcatUpperUpper(d4, t2, t0);
  *c3 = hn::ConcatUpperUpper(d4, t3, t1);
}

// The coefficients (c0, c1, c2, c3) of the table rows at[0 .. Lanes(d)), one vector each: lane i
// of c_j is table[4 at[i] + j]. Loads of whole rows and an in-register transpose where the vector
// width is known (gather instructions were slower on AVX-512 here); gathers on SVE.
template <class D, class V = hn::Vec<D>>
HWY_INLINE void LoadRows(D d, const double* table, const int32_t* at, V* c0, V* c1, V* c2, V* c3) {
#if HWY_HAVE_SCALABLE
  const hn::Rebind<int64_t, D> di;
  const auto index = hn::ShiftLeft<2>(hn::PromoteTo(di, hn::LoadU(hn::Rebind<int32_t, D>(), at)));
  *c0 = hn::GatherIndex(d, table, index);
  *c1 = hn::GatherIndex(d, table + 1, index);
  *c2 = hn::GatherIndex(d, table + 2, index);
  *c3 = hn::GatherIndex(d, table + 3, index);
#else
  constexpr size_t kN = hn::MaxLanes(D());
  if constexpr (kN == 2) {
    const V a01 = hn::LoadU(d, table + ptrdiff_t{4} * at[0]);
    const V a23 = hn::LoadU(d, table + ptrdiff_t{4} * at[0] + 2);
    const V b01 = hn::LoadU(d, table + ptrdiff_t{4} * at[1]);
    const V b23 = hn::LoadU(d, table + ptrdiff_t{4} * at[1] + 2);
    *c0 = hn::InterleaveLower(d, a01, b01);
    *c1 = hn::InterleaveUpper(d, a01, b01);
    *c2 = hn::InterleaveLower(d, a23, b23);
    *c3 = hn::InterleaveUpper(d, a23, b23);
  } else if constexpr (kN == 4) {
    TransposeRows4(d, table, at, c0, c1, c2, c3);
  } else {
    static_assert(kN == 8, "two, four or eight lanes of doubles");
    const hn::Half<D> dh;
    hn::Vec<hn::Half<D>> lo[4], hi[4];
    TransposeRows4(dh, table, at, &lo[0], &lo[1], &lo[2], &lo[3]);
    TransposeRows4(dh, table, at + 4, &hi[0], &hi[1], &hi[2], &hi[3]);
    *c0 = hn::Combine(d, hi[0], lo[0]);
    *c1 = hn::Combine(d, hi[1], lo[1]);
    *c2 = hn::Combine(d, hi[2], lo[2]);
    *c3 = hn::Combine(d, hi[3], lo[3]);
  }
#endif
}

// ReturnLikelihoodEvaluator::Hermite in every lane: index min(trunc(s), last) (s is also clamped
// at 0, which only changes lanes whose value is not used), t = s - index, and
// c0 + t (c1 + t (c2 + t c3)) with the same roundings.
template <class D, class V = hn::Vec<D>>
HWY_INLINE V HermiteLanes(D d, const double* table, double last, V s) {
  const hn::Rebind<int32_t, D> di;
  const V s_in = MaxLikeScalar(d, MinLikeScalar(d, s, hn::Set(d, last)), hn::Zero(d));
  const auto index = hn::DemoteTo(di, s_in);  // truncation, as the scalar conversion
  const V t = hn::Sub(s, hn::PromoteTo(d, index));
  alignas(64) int32_t at[lanes::kLanes];
  hn::StoreU(index, di, at);
  V c0, c1, c2, c3;
  LoadRows(d, table, at, &c0, &c1, &c2, &c3);
  const V inner = hn::Add(c2, hn::Mul(t, c3));
  const V mid = hn::Add(c1, hn::Mul(t, inner));
  return hn::Add(c0, hn::Mul(t, mid));
}

// kernels::FillLikelihoodsFn: SensorModel::ReturnLikelihood / NoReturnProbability in every lane,
// a row of Lanes(D8) lanes at a time.
void FillLikelihoods(const LikelihoodLanes& c, const double* lo, const double* z,
                     const double* scale_of_lane, unsigned is_return, const double* distance_m,
                     int rows, double* likelihood) {
  const ZeroUpperOnReturn zero_upper;
  const D8 d;
  using V = hn::Vec<D8>;
  const V z_min = hn::Set(d, c.z_min), z_max = hn::Set(d, c.z_max);
  const V cutoff = hn::Set(d, c.cutoff), spurious = hn::Set(d, c.spurious);
  const V zero = hn::Zero(d);
  const V g_per_m = hn::Set(d, c.gaussian_index_per_m);
  const V m_per_m = hn::Set(d, c.mass_index_per_m);
  const V near_none = hn::Set(d, c.near_none);
  const V in_range_none = hn::Set(d, c.in_range_none);
  const size_t n = hn::Lanes(d);
  for (size_t first = 0; first < static_cast<size_t>(lanes::kLanes); first += n) {
    const V v_lo = hn::LoadU(d, lo + first);
    const V v_z = hn::LoadU(d, z + first);
    const V scale = hn::LoadU(d, scale_of_lane + first);
    const auto returns = LaneBits(d, is_return, first);
    for (int k = 0; k < rows; ++k) {
      const ptrdiff_t at =
          static_cast<ptrdiff_t>(k) * lanes::kLanes + static_cast<ptrdiff_t>(first);
      const V dk = hn::LoadU(d, distance_m + at);
      // d >= z_min && d < z_max (ordered: false for NaN, as in the scalar code).
      const auto in_range = hn::And(hn::Ge(dk, z_min), hn::Lt(dk, z_max));
      const V none = hn::IfThenElse(in_range, in_range_none, near_none);
      // Return lanes: the spurious term outside the window, p_rand u + scale G(r) / D(d) inside.
      // The distance from d to the band [lo, z]: |z - d| without a band.
      const V r = hn::Max(hn::Max(hn::Sub(v_lo, dk), hn::Sub(dk, v_z)), zero);
      const auto window = hn::And(hn::And(returns, in_range), hn::Le(r, cutoff));
      V a = hn::IfThenElse(returns, spurious, none);
      if (!hn::AllFalse(d, window)) {
        const V g = HermiteLanes(d, c.gaussian_table, c.gaussian_last, hn::Mul(r, g_per_m));
        const V m =
            HermiteLanes(d, c.inv_mass_table, c.mass_last, hn::Mul(hn::Sub(dk, z_min), m_per_m));
        const V ret = hn::Add(spurious, hn::Mul(hn::Mul(scale, g), m));
        a = hn::IfThenElse(window, ret, a);
      }
      hn::StoreU(a, d, likelihood + at);
    }
  }
}

}  // namespace kestrel::kernels::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // KESTREL_MAPPING_KERNELS_LIKELIHOODS_INL_H_

#include "mapping/sensor_model.h"

#include <limits>

#include "common/check.h"
#include "mapping/avx512.h"

namespace kestrel {

SensorModelConfig SensorModelConfig::Xtion() {
  SensorModelConfig c;
  c.sigma_m = 0.25;
  return c;
}

SensorModelConfig SensorModelConfig::Hokuyo() {
  SensorModelConfig c;
  c.sigma_m = 0.1;
  return c;
}

void SensorModelConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(sigma_m) && sigma_m > 0.0,
                       "sensor model sigma_m = " << sigma_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(z_min_m) && z_min_m >= 0.0,
                       "sensor model z_min_m = " << z_min_m << ", accepted [0, z_max_m)");
  KESTREL_THROW_UNLESS(
      std::isfinite(z_max_m) && z_max_m > z_min_m,
      "sensor model z_max_m = " << z_max_m << ", accepted (z_min_m = " << z_min_m << ", inf)");
  KESTREL_THROW_UNLESS(p_rand > 0.0 && p_rand < 1.0,
                       "sensor model p_rand = " << p_rand << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(p_miss > 0.0 && p_miss < 1.0,
                       "sensor model p_miss = " << p_miss << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(cutoff_sigmas >= 5.0,
                       "sensor model cutoff_sigmas = " << cutoff_sigmas << ", accepted [5, inf]");
}

SensorModel::SensorModel(const SensorModelConfig& config) : config_(config) {
  config_.Validate();
  uniform_density_ = 1.0 / (config_.z_max_m - config_.z_min_m);
  spurious_density_ = config_.p_rand * uniform_density_;
  gaussian_scale_ =
      (1.0 - config_.p_rand) * (1.0 - config_.p_miss) / (config_.sigma_m * std::sqrt(2.0 * M_PI));
  inv_sigma2_ = 1.0 / (config_.sigma_m * config_.sigma_m);
  inv_sigma_sqrt2_ = 1.0 / (config_.sigma_m * std::sqrt(2.0));
  cutoff_m_ = config_.cutoff_sigmas * config_.sigma_m;
  in_range_no_return_ = (1.0 - config_.p_rand) * config_.p_miss;
  if (config_.interpolated_gaussian && std::isfinite(config_.cutoff_sigmas)) {
    // exp(-x^2/2) at nodes x = i/512, slope -x exp(-x^2/2) (times the step).
    constexpr double kStepX = 1.0 / 512.0;
    const size_t nx = static_cast<size_t>(std::ceil(config_.cutoff_sigmas / kStepX)) + 2;
    const auto gauss = [&](size_t i, double* y, double* m) {
      const double x = static_cast<double>(i) * kStepX;
      *y = std::exp(-0.5 * x * x);
      *m = -x * *y * kStepX;
    };
    for (size_t i = 0; i + 1 < nx; ++i) {
      double y0, m0, y1, m1;
      gauss(i, &y0, &m0);
      gauss(i + 1, &y1, &m1);
      AppendInterval(y0, m0, y1, m1, &gaussian_table_);
    }
    gaussian_last_ = nx - 2;
    gaussian_index_per_m_ = 1.0 / (config_.sigma_m * kStepX);
    // 1/D(d) at nodes d = z_min + i h, h = sigma/256; slope -D'/D^2 (times h) with
    // D'(d) = (phi((z_min - d)/sigma) - phi((z_max - d)/sigma)) / sigma.
    const double h = config_.sigma_m / 256.0;
    const size_t nd = static_cast<size_t>(std::ceil((config_.z_max_m - config_.z_min_m) / h)) + 2;
    const auto phi = [](double x) { return std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI); };
    const auto inv_mass = [&](size_t i, double* y, double* m) {
      const double d = config_.z_min_m + static_cast<double>(i) * h;
      const double mass = TruncationMass(d);
      const double slope = (phi((config_.z_min_m - d) / config_.sigma_m) -
                            phi((config_.z_max_m - d) / config_.sigma_m)) /
                           config_.sigma_m;
      *y = 1.0 / mass;
      *m = -slope / (mass * mass) * h;
    };
    for (size_t i = 0; i + 1 < nd; ++i) {
      double y0, m0, y1, m1;
      inv_mass(i, &y0, &m0);
      inv_mass(i + 1, &y1, &m1);
      AppendInterval(y0, m0, y1, m1, &inv_mass_table_);
    }
    mass_last_ = nd - 2;
    mass_index_per_m_ = 1.0 / h;
  }
}

double ReturnLikelihoodEvaluator::Direct(double r, double d_m) const {
  // Section 3: p_rand u + (1 - p_rand)(1 - p_miss) G_k(z), direct.
  return spurious_density_ + model_->DirectGaussianTerm(r, d_m);
}

#if defined(__x86_64__)
namespace {

// The constants of one FillLikelihoods call.
struct LikelihoodLanes {
  const double* gaussian_table;
  const double* inv_mass_table;
  double gaussian_last, mass_last;  // last interval, as doubles
  double gaussian_index_per_m, mass_index_per_m;
  double z_min, z_max, cutoff, spurious, scale;
  double near_none, in_range_none;  // P(none | r_k+) below z_min / in range
};

KESTREL_AVX512_BEGIN

// ReturnLikelihoodEvaluator::Hermite in eight lanes: index min(trunc(s), last) (s is also
// clamped at 0, which only changes lanes whose value is not used), t = s - index, and
// c0 + t (c1 + t (c2 + t c3)) with the same roundings. Each lane's four coefficients are one
// 32-byte load; an in-register transpose turns the eight loads into c0..c3 (gather
// instructions are slower here).
[[KESTREL_AVX512, gnu::always_inline]] inline __m512d HermiteLanes(const double* table, double last,
                                                                   __m512d s) {
  const __m512d s_in = _mm512_max_pd(_mm512_min_pd(s, _mm512_set1_pd(last)), _mm512_setzero_pd());
  const __m256i index = _mm512_cvttpd_epi32(s_in);
  const __m512d t = _mm512_sub_pd(s, _mm512_cvtepi32_pd(index));
  alignas(32) int32_t at[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(at), index);
  // Rows of two lanes' coefficients: [c0 c1 c2 c3 | c0 c1 c2 c3] of lanes (0,1), (2,3), ...
  __m512d pair[4];
  const auto row = [&](int lane) { return table + ptrdiff_t{4} * at[lane]; };
  for (int p = 0; p < 4; ++p) {
    const __m512d low = _mm512_castpd256_pd512(_mm256_loadu_pd(row(2 * p)));
    pair[p] = _mm512_insertf64x4(low, _mm256_loadu_pd(row(2 * p + 1)), 1);
  }
  // [c0 of lanes 0-3 | c1 of lanes 0-3] and [c2 | c3] from pairs (0,1); likewise lanes 4-7.
  const __m512i even = _mm512_setr_epi64(0, 4, 8, 12, 1, 5, 9, 13);
  const __m512i odd = _mm512_setr_epi64(2, 6, 10, 14, 3, 7, 11, 15);
  const __m512d c01_lo = _mm512_permutex2var_pd(pair[0], even, pair[1]);
  const __m512d c23_lo = _mm512_permutex2var_pd(pair[0], odd, pair[1]);
  const __m512d c01_hi = _mm512_permutex2var_pd(pair[2], even, pair[3]);
  const __m512d c23_hi = _mm512_permutex2var_pd(pair[2], odd, pair[3]);
  const __m512d c0 = _mm512_shuffle_f64x2(c01_lo, c01_hi, 0x44);  // low halves
  const __m512d c1 = _mm512_shuffle_f64x2(c01_lo, c01_hi, 0xEE);  // high halves
  const __m512d c2 = _mm512_shuffle_f64x2(c23_lo, c23_hi, 0x44);
  const __m512d c3 = _mm512_shuffle_f64x2(c23_lo, c23_hi, 0xEE);
  const __m512d inner = _mm512_add_pd(c2, _mm512_mul_pd(t, c3));
  const __m512d mid = _mm512_add_pd(c1, _mm512_mul_pd(t, inner));
  return _mm512_add_pd(c0, _mm512_mul_pd(t, mid));
}

[[KESTREL_AVX512]] void FillLikelihoodsAvx512(const LikelihoodLanes& c, const double* z,
                                              __mmask8 is_return, const double* distance_m,
                                              int rows, double* likelihood) {
  const __m512d v_z = _mm512_loadu_pd(z);
  const __m512d z_min = _mm512_set1_pd(c.z_min), z_max = _mm512_set1_pd(c.z_max);
  const __m512d cutoff = _mm512_set1_pd(c.cutoff), spurious = _mm512_set1_pd(c.spurious);
  const __m512d scale = _mm512_set1_pd(c.scale);
  const __m512d g_per_m = _mm512_set1_pd(c.gaussian_index_per_m);
  const __m512d m_per_m = _mm512_set1_pd(c.mass_index_per_m);
  const __m512d near_none = _mm512_set1_pd(c.near_none);
  const __m512d in_range_none = _mm512_set1_pd(c.in_range_none);
  for (int k = 0; k < rows; ++k) {
    const __m512d d = _mm512_loadu_pd(distance_m + static_cast<ptrdiff_t>(k) * 8);
    // d >= z_min && d < z_max (ordered: false for NaN, as in the scalar code).
    const __mmask8 in_range =
        _mm512_cmp_pd_mask(d, z_min, _CMP_GE_OQ) & _mm512_cmp_pd_mask(d, z_max, _CMP_LT_OQ);
    const __m512d none = _mm512_mask_blend_pd(in_range, near_none, in_range_none);
    // Return lanes: the spurious term outside the window, p_rand u + scale G(r) / D(d) inside.
    const __m512d r = _mm512_abs_pd(_mm512_sub_pd(v_z, d));  // |z - d|
    const __mmask8 window = is_return & in_range & _mm512_cmp_pd_mask(r, cutoff, _CMP_LE_OQ);
    __m512d a = _mm512_mask_blend_pd(is_return, none, spurious);
    if (window != 0) {
      const __m512d g = HermiteLanes(c.gaussian_table, c.gaussian_last, _mm512_mul_pd(r, g_per_m));
      const __m512d m = HermiteLanes(c.inv_mass_table, c.mass_last,
                                     _mm512_mul_pd(_mm512_sub_pd(d, z_min), m_per_m));
      const __m512d ret = _mm512_add_pd(spurious, _mm512_mul_pd(_mm512_mul_pd(scale, g), m));
      a = _mm512_mask_blend_pd(window, a, ret);
    }
    _mm512_storeu_pd(likelihood + static_cast<ptrdiff_t>(k) * 8, a);
  }
}
KESTREL_AVX512_END

}  // namespace
#endif

bool SensorModel::FillLikelihoods(const Reading* readings, int count, const double* distance_m,
                                  int rows, double* likelihood, lanes::Isa isa) const {
  static_assert(lanes::kLanes == 8, "one AVX-512 register of doubles per row");
  KESTREL_THROW_UNLESS(count >= 0 && count <= lanes::kLanes && rows >= 0,
                       "FillLikelihoods: count = " << count << ", rows = " << rows
                                                   << ", accepted count in [0, 8], rows >= 0");
#if defined(__x86_64__)
  if (isa != lanes::Isa::kAvx512 || gaussian_table_.empty()) return false;
  alignas(64) double z[lanes::kLanes] = {};
  unsigned is_return = 0;
  for (int l = 0; l < count; ++l) {
    if (readings[l].kind == ReadingKind::kReturn) {
      z[l] = readings[l].z_m;
      is_return |= 1u << l;
    }
  }
  const ReturnLikelihoodEvaluator e = ReturnEvaluator();
  const LikelihoodLanes c{e.gaussian_table_,
                          e.inv_mass_table_,
                          static_cast<double>(e.gaussian_last_),
                          static_cast<double>(e.mass_last_),
                          e.gaussian_index_per_m_,
                          e.mass_index_per_m_,
                          config_.z_min_m,
                          config_.z_max_m,
                          e.cutoff_m_,
                          e.spurious_density_,
                          e.gaussian_scale_,
                          1.0 - config_.p_rand,
                          in_range_no_return_};
  FillLikelihoodsAvx512(c, z, static_cast<__mmask8>(is_return), distance_m, rows, likelihood);
  return true;
#else
  (void)readings;
  (void)distance_m;
  (void)likelihood;
  (void)isa;
  return false;
#endif
}

Reading SensorModel::Classify(double range_m) const {
  if (std::isnan(range_m) || range_m < config_.z_min_m) return {ReadingKind::kInvalid, 0.0};
  if (range_m >= config_.z_max_m) return {ReadingKind::kNoReturn, 0.0};
  return {ReadingKind::kReturn, range_m};
}

double SensorModel::TruncationMass(double d_m) const {
  // 1 - Q_upper - Q_lower with Q(x) = erfc(x/sqrt 2)/2, the tails above z_max and below z_min.
  // Beyond 9 sigma a tail is below 1.2e-19 and cannot change 1 - (other tail) in double.
  const double upper = (config_.z_max_m - d_m) * inv_sigma_sqrt2_;  // (z_max - d)/(sigma sqrt 2)
  const double lower = (d_m - config_.z_min_m) * inv_sigma_sqrt2_;  // (d - z_min)/(sigma sqrt 2)
  constexpr double kNegligible = 9.0 / 1.4142135623730951;
  const double q_upper = upper > kNegligible ? 0.0 : 0.5 * std::erfc(upper);
  const double q_lower = lower > kNegligible ? 0.0 : 0.5 * std::erfc(lower);
  return 1.0 - q_upper - q_lower;
}

}  // namespace kestrel

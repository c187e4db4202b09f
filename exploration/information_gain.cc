#include "exploration/information_gain.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/check.h"
#include "mapping/kernels/avx512.h"
#include "mapping/kernels/kernels.h"
#include "mapping/occupancy_updater.h"
#include "mapping/range_bands.h"

namespace kestrel {
namespace {

constexpr double kInvSqrt2 = 0.70710678118654752440;

// Phi(x2) - Phi(x1) for x1 <= x2, without cancellation in either tail.
double StandardNormalMass(double x1, double x2) {
  if (x1 >= 0.0) return 0.5 * (std::erfc(x1 * kInvSqrt2) - std::erfc(x2 * kInvSqrt2));
  if (x2 <= 0.0) return 0.5 * (std::erfc(-x2 * kInvSqrt2) - std::erfc(-x1 * kInvSqrt2));
  return 1.0 - 0.5 * std::erfc(x2 * kInvSqrt2) - 0.5 * std::erfc(-x1 * kInvSqrt2);
}

// The Gaussian part of P(z in [a, b) | r_i+) for an in-range d, given 1/TruncationMass(d).
double GaussianIntervalMass(const SensorModelConfig& c, double d, double inv_mass, double a,
                            double b) {
  const double cutoff = c.cutoff_sigmas * c.sigma_m;
  const double a2 = std::max(a, d - cutoff);  // the model's window, sensor_model.h
  const double b2 = std::min(b, d + cutoff);
  if (!(b2 > a2)) return 0.0;
  const double scale = (1.0 - c.p_rand) * (1.0 - c.p_miss) * inv_mass;
  return scale * StandardNormalMass((a2 - d) / c.sigma_m, (b2 - d) / c.sigma_m);
}

bool InRange(const SensorModelConfig& c, double d) { return d >= c.z_min_m && d < c.z_max_m; }

#if defined(__x86_64__)
KESTREL_AVX512_BEGIN
// ln x for finite x > 0 in eight lanes: x = m 2^k with m in [0.75, 1.5) (getmant/getexp), then
// ln m = 2 atanh(f), f = (m - 1)/(m + 1), |f| <= 0.2, by its series to f^21 (truncation below
// 2e-17 relative), and k ln 2 in two parts. A few ulp.
[[KESTREL_AVX512]] inline __m512d Log8(__m512d x) {
  const __m512d m = _mm512_getmant_pd(x, _MM_MANT_NORM_p75_1p5, _MM_MANT_SIGN_src);
  const __m512d one = _mm512_set1_pd(1.0);
  __m512d k = _mm512_getexp_pd(x);
  k = _mm512_mask_add_pd(k, _mm512_cmp_pd_mask(m, one, _CMP_LT_OQ), k, one);  // m = mant / 2
  const __m512d f = _mm512_div_pd(_mm512_sub_pd(m, one), _mm512_add_pd(m, one));
  const __m512d s = _mm512_mul_pd(f, f);
  // 1 + s/3 + s^2/5 + ... + s^10/21, Horner.
  __m512d p = _mm512_set1_pd(1.0 / 21.0);
  for (int i = 9; i >= 0; --i) {
    p = _mm512_add_pd(_mm512_mul_pd(p, s), _mm512_set1_pd(1.0 / (2 * i + 1)));
  }
  const __m512d ln_m = _mm512_mul_pd(_mm512_add_pd(f, f), p);
  constexpr double kLn2Hi = 6.93147180369123816490e-01;  // 0x3fe62e42fee00000
  constexpr double kLn2Lo = 1.90821492927058770002e-10;
  return _mm512_add_pd(_mm512_mul_pd(k, _mm512_set1_pd(kLn2Hi)),
                       _mm512_add_pd(_mm512_mul_pd(k, _mm512_set1_pd(kLn2Lo)), ln_m));
}

// The lanes of eight that lie below the end of an array with `left` elements still to go.
inline __mmask8 TailMask(int left) {
  return left >= 8 ? static_cast<__mmask8>(0xFF) : static_cast<__mmask8>((1u << left) - 1u);
}

// p ln p + (1 - p) ln(1 - p) = -H(p) in eight lanes; *inside: the lanes of `load` with p in
// (0, 1), where H is not 0 (the others compute at 0.5: no log(0)).
[[KESTREL_AVX512]] inline __m512d MinusEntropy8(__m512d v, __mmask8 load, __mmask8* inside) {
  const __m512d one = _mm512_set1_pd(1.0);
  *inside = static_cast<__mmask8>(load & _mm512_cmp_pd_mask(v, _mm512_setzero_pd(), _CMP_GT_OQ) &
                                  _mm512_cmp_pd_mask(v, one, _CMP_LT_OQ));
  const __m512d x = _mm512_mask_blend_pd(*inside, _mm512_set1_pd(0.5), v);
  const __m512d q = _mm512_sub_pd(one, x);
  return _mm512_add_pd(_mm512_mul_pd(x, Log8(x)), _mm512_mul_pd(q, Log8(q)));
}

// sum_j w[j] H(p[j]) (w null: 1), j < n, eight at a time (H = 0 outside (0, 1), as
// BinaryEntropy).
[[KESTREL_AVX512]] double SumBinaryEntropyAvx512(const double* p, const double* w, int n) {
  __m512d acc = _mm512_setzero_pd();
  for (int j = 0; j < n; j += 8) {
    const __mmask8 load = TailMask(n - j);
    __mmask8 inside = 0;
    __m512d h = MinusEntropy8(_mm512_maskz_loadu_pd(load, p + j), load, &inside);
    if (w != nullptr) h = _mm512_mul_pd(h, _mm512_maskz_loadu_pd(load, w + j));
    acc = _mm512_mask_sub_pd(acc, inside, acc, h);
  }
  return _mm512_reduce_add_pd(acc);
}

// sum_i a[i] b[i], i < n, in eight partial sums.
[[KESTREL_AVX512]] double DotAvx512(const double* a, const double* b, int n) {
  __m512d acc = _mm512_setzero_pd();
  for (int i = 0; i < n; i += 8) {
    const __mmask8 load = TailMask(n - i);
    acc = _mm512_add_pd(
        acc, _mm512_mul_pd(_mm512_maskz_loadu_pd(load, a + i), _mm512_maskz_loadu_pd(load, b + i)));
  }
  return _mm512_reduce_add_pd(acc);
}

// h[j] = H(p[j]), j < n, eight at a time (0 outside (0, 1)).
[[KESTREL_AVX512]] void BinaryEntropiesAvx512(const double* p, double* h, int n) {
  const __m512d zero = _mm512_setzero_pd();
  for (int j = 0; j < n; j += 8) {
    const __mmask8 load = TailMask(n - j);
    __mmask8 inside = 0;
    const __m512d e = MinusEntropy8(_mm512_maskz_loadu_pd(load, p + j), load, &inside);
    _mm512_mask_storeu_pd(h + j, load, _mm512_maskz_sub_pd(inside, zero, e));
  }
}
KESTREL_AVX512_END
#endif

// sum_i a[i] b[i], i < n (lanes: eight partial sums on AVX-512).
double Dot(const double* a, const double* b, int n, bool lanes) {
#if defined(__x86_64__)
  if (lanes) return DotAvx512(a, b, n);
#else
  (void)lanes;
#endif
  double s = 0.0;
  for (int i = 0; i < n; ++i) s += a[i] * b[i];
  return s;
}

// sum_j w[j] H(p[j]) (w null: 1), j < n, as EntropySum says.
double SumBinaryEntropy(const double* p, const double* w, int n, bool lanes) {
#if defined(__x86_64__)
  if (lanes) return SumBinaryEntropyAvx512(p, w, n);
#else
  (void)lanes;
#endif
  double h = 0.0;
  for (int j = 0; j < n; ++j) h += (w != nullptr ? w[j] : 1.0) * BinaryEntropy(p[j]);
  return h;
}

}  // namespace

double ReturnIntervalProbability(const SensorModel& model, double d_m, double a_m, double b_m) {
  const SensorModelConfig& c = model.config();
  double p = model.spurious_density() * std::max(0.0, b_m - a_m);  // uniform term
  if (InRange(c, d_m)) p += GaussianIntervalMass(c, d_m, 1.0 / model.TruncationMass(d_m), a_m, b_m);
  return p;
}

void ExpectedEntropyScratch::Reserve(int n) {
  const size_t s = static_cast<size_t>(n) + 2;
  if (isms_.capacity() < n + 1) isms_ = InverseSensorModelScratch(2 * n + 16);
  for (auto* v : {&posterior_, &pi_, &pbar_before_, &pi_prefix_, &suffix_h_, &trunc_mass_, &z_, &q_,
                  &values_, &counts_, &eta_inv_, &in_lo_, &in_hi_}) {
    if (v->size() < s) v->resize(2 * s);
  }
}

RayEntropy ExpectedEntropy::Compute(const SensorModel& model, const double* entry_m,
                                    const double* exit_m, const double* distance_m,
                                    const double* prior, int n, WeightMode mode, GainMethod method,
                                    ExpectedEntropyScratch* scratch, ExpectedEntropyTerms* terms,
                                    const double* cos_incidence) {
  KESTREL_THROW_UNLESS(n >= 0, "ExpectedEntropy: n = " << n << ", accepted >= 0");
  KESTREL_THROW_UNLESS(scratch != nullptr, "ExpectedEntropy: scratch is null");
  KESTREL_THROW_UNLESS(n == 0 || (entry_m != nullptr && exit_m != nullptr &&
                                  distance_m != nullptr && prior != nullptr),
                       "ExpectedEntropy: null input with n = " << n);
  scratch->Reserve(n);
  if (method == GainMethod::kDirect || terms != nullptr) {
    return Direct(model, entry_m, exit_m, distance_m, prior, n, mode, scratch, terms,
                  cos_incidence);
  }
  return Fast(model, entry_m, exit_m, distance_m, prior, n, mode, scratch, cos_incidence);
}

RayEntropy ExpectedEntropy::Direct(const SensorModel& model, const double* entry_m,
                                   const double* exit_m, const double* distance_m,
                                   const double* prior, int n, WeightMode mode,
                                   ExpectedEntropyScratch* scratch, ExpectedEntropyTerms* terms,
                                   const double* cos_incidence) {
  const SensorModelConfig& c = model.config();
  const bool bands = cos_incidence != nullptr && c.direction_uncertainty_rad > 0.0;
  double* const pi = scratch->pi_.data();
  double* const post = scratch->posterior_.data();
  double pbar = 1.0;
  RayEntropy out;
  for (int j = 0; j < n; ++j) {
    pi[j] = prior[j] * pbar;  // pi_j, section 4
    pbar *= 1.0 - prior[j];
    out.prior_entropy_nats += BinaryEntropy(prior[j]);
  }
  const double pi_empty = pbar;  // pi_(n+1)
  if (terms != nullptr) {
    terms->hypothesis_z_m.assign(static_cast<size_t>(n) + 1,
                                 std::numeric_limits<double>::quiet_NaN());
    terms->weight_unnormalised.assign(static_cast<size_t>(n) + 1, 0.0);
    terms->posterior_entropy_nats.assign(static_cast<size_t>(n) + 1, 0.0);
  }
  // H_k from the mapper's exact update; cells it does not write keep their prior.
  const auto posterior_entropy = [&](const Reading& reading, double* inv_eta) {
    const ExactUpdateResult r =
        ComputeExactPosteriors(model, reading, distance_m, prior, n, post, &scratch->isms_);
    double h = 0.0;
    for (int j = 0; j < n; ++j) {
      const bool written = j >= r.first && j < r.first + r.count;
      h += BinaryEntropy(written ? post[j] : prior[j]);
    }
    *inv_eta = r.inv_eta;
    return h;
  };
  double weight_sum = 0.0;
  double weighted_h = 0.0;
  for (int k = 0; k < n; ++k) {
    const double lo = std::max(entry_m[k], c.z_min_m);
    const double hi = std::min(exit_m[k], c.z_max_m);
    if (!(hi > lo)) continue;  // chord outside [z_min, z_max): the sensor cannot return here
    const double z = 0.5 * (lo + hi);
    double q = pi_empty * model.spurious_density() * (hi - lo);  // empty ray: uniform only
    for (int i = 0; i < n; ++i) {
      q += pi[i] * ReturnIntervalProbability(model, distance_m[i], lo, hi);  // section 6 q_k
    }
    double inv_eta = 0.0;
    const Reading reading =
        bands ? PredictedBandedReturn(c, z, cos_incidence[k]) : Reading{ReadingKind::kReturn, z};
    const double h = posterior_entropy(reading, &inv_eta);
    const double w = mode == WeightMode::kChordProbability ? q : inv_eta;  // eq. (8) literal
    weight_sum += w;
    weighted_h += w * h;
    if (terms != nullptr) {
      terms->hypothesis_z_m[static_cast<size_t>(k)] = z;
      terms->weight_unnormalised[static_cast<size_t>(k)] = w;
      terms->posterior_entropy_nats[static_cast<size_t>(k)] = h;
    }
  }
  {
    double q = pi_empty * model.empty_no_return_probability();  // q_(n+1) = P(no return)
    for (int i = 0; i < n; ++i) q += pi[i] * model.NoReturnProbability(distance_m[i]);
    double inv_eta = q;
    // A sensor whose "no return" is no evidence leaves the map as it was: the hypothesis keeps
    // the prior entropy (docs/algorithms.md §3.4).
    double h = 0.0;
    if (c.no_return_informs) {
      h = posterior_entropy(Reading{ReadingKind::kNoReturn, 0.0}, &inv_eta);
    } else {
      h = out.prior_entropy_nats;
    }
    const double w = mode == WeightMode::kChordProbability ? q : inv_eta;
    weight_sum += w;
    weighted_h += w * h;
    if (terms != nullptr) {
      terms->weight_unnormalised[static_cast<size_t>(n)] = w;
      terms->posterior_entropy_nats[static_cast<size_t>(n)] = h;
    }
  }
  KESTREL_DEMAND(weight_sum > 0.0);
  out.expected_entropy_nats = weighted_h / weight_sum;  // eq. (7)
  return out;
}

void RayKernel::Build(const SensorModel& model, const double* entry_m, const double* exit_m,
                      const double* distance_m, int n, const double* cos_incidence) {
  const SensorModelConfig& c = model.config();
  const double c0 = model.spurious_density();
  const double cutoff = c.cutoff_sigmas * c.sigma_m;
  // Predicted range bands (docs/algorithms.md §3.8): only with a model that has them.
  const bool bands = cos_incidence != nullptr && c.direction_uncertainty_rad > 0.0;
  n_ = n;
  entry_m_.assign(entry_m, entry_m + n);
  exit_m_.assign(exit_m, exit_m + n);
  distance_m_.assign(distance_m, distance_m + n);
  if (bands) {
    cos_incidence_.assign(cos_incidence, cos_incidence + n);
  } else {
    cos_incidence_.clear();
  }
  hypotheses_.clear();
  g_.clear();
  a_.clear();
  no_return_.resize(static_cast<size_t>(n));
  std::vector<double> inv_mass(static_cast<size_t>(n));
  std::vector<Reading> readings;  // the banded hypotheses' readings
  near_cells_ = 0;
  for (int j = 0; j < n; ++j) {
    inv_mass[static_cast<size_t>(j)] =
        InRange(c, distance_m[j]) ? 1.0 / model.TruncationMass(distance_m[j]) : 0.0;
    no_return_[static_cast<size_t>(j)] = model.NoReturnProbability(distance_m[j]);
    if (distance_m[j] < c.z_min_m) near_cells_ = j + 1;  // d non-decreasing: a prefix
  }
  int end = 0, lo_cell = 0, q_first = 0;
  for (int k = 0; k < n; ++k) {
    const double lo = std::max(entry_m[k], c.z_min_m);
    const double hi = std::min(exit_m[k], c.z_max_m);
    if (!(hi > lo)) continue;  // chord outside [z_min, z_max): q_k = 0
    Hypothesis h;
    h.k = k;
    h.z_m = 0.5 * (lo + hi);
    h.uniform_q = c0 * (hi - lo);  // the uniform term, weight sum_i pi_i + pi_empty = 1
    // (a) Gaussian part of q_k from the cells whose window reaches the chord.
    while (q_first < n && distance_m[q_first] + cutoff <= lo) ++q_first;
    h.g_first = q_first;
    h.g_offset = g_.size();
    for (int i = q_first; i < n && distance_m[i] - cutoff < hi; ++i) {
      const double mass = inv_mass[static_cast<size_t>(i)];
      g_.push_back(mass > 0.0 ? GaussianIntervalMass(c, distance_m[i], mass, lo, hi) : 0.0);
    }
    h.g_count = static_cast<int>(g_.size() - h.g_offset);
    h.tail_a = c0;
    if (bands) {
      // The mapper's cells and a_j for the banded return (ExactUpdate::Forward): those before
      // the band's near end for a surface_unknown return, else up to z + c sigma.
      const Reading r = PredictedBandedReturn(c, h.z_m, cos_incidence[k]);
      h.end = ReturnCellsEnd(model, r, distance_m, n);
      h.lo = 0;
      while (h.lo < h.end && model.ReturnLikelihood(r, distance_m[h.lo]) == c0) ++h.lo;
      h.tail_a = model.EmptyRayLikelihood(r);
      readings.push_back(r);
      hypotheses_.push_back(h);
      continue;
    }
    // (b) cells beyond z + c sigma keep their prior (the mapper's shortcut).
    const double reach = model.GaussianReach(h.z_m);
    while (end < n && distance_m[end] <= reach) ++end;
    // (c) leading cells whose a_j is the spurious density.
    while (lo_cell < end && model.ReturnLikelihood(h.z_m, distance_m[lo_cell]) == c0) ++lo_cell;
    h.end = end;
    h.lo = lo_cell;
    h.a_offset = a_.size();
    for (int j = lo_cell; j < end; ++j) a_.push_back(model.ReturnLikelihood(h.z_m, distance_m[j]));
    hypotheses_.push_back(h);
  }
  if (bands) {
    // Evaluate groups the cells before lo once, so lo must not decrease from one hypothesis to
    // the next: take the suffix minimum (the cells this adds have a_j = p_rand u, stored).
    for (size_t i = hypotheses_.size(); i-- > 1;) {
      hypotheses_[i - 1].lo = std::min(hypotheses_[i - 1].lo, hypotheses_[i].lo);
    }
    for (size_t i = 0; i < hypotheses_.size(); ++i) {
      Hypothesis& h = hypotheses_[i];
      h.a_offset = a_.size();
      for (int j = h.lo; j < h.end; ++j) {
        a_.push_back(model.ReturnLikelihood(readings[i], distance_m[j]));
      }
    }
  }
}

bool RayKernel::Matches(const double* entry_m, const double* exit_m, const double* distance_m,
                        int n, const double* cos_incidence) const {
  if (n > n_) return false;
  if ((cos_incidence != nullptr) != !cos_incidence_.empty()) return false;
  constexpr double kTolerance_m = 1e-12;
  for (int j = 0; j < n; ++j) {
    const size_t u = static_cast<size_t>(j);
    if (std::abs(entry_m[j] - entry_m_[u]) > kTolerance_m ||
        std::abs(exit_m[j] - exit_m_[u]) > kTolerance_m ||
        std::abs(distance_m[j] - distance_m_[u]) > kTolerance_m ||
        (cos_incidence != nullptr && cos_incidence[j] != cos_incidence_[u])) {
      return false;
    }
  }
  return true;
}

RayEntropy ExpectedEntropy::Fast(const SensorModel& model, const double* entry_m,
                                 const double* exit_m, const double* distance_m,
                                 const double* prior, int n, WeightMode mode,
                                 ExpectedEntropyScratch* scratch, const double* cos_incidence) {
  scratch->kernel_.Build(model, entry_m, exit_m, distance_m, n, cos_incidence);
  return Evaluate(model, scratch->kernel_, prior, n, mode, scratch);
}

RayEntropy ExpectedEntropy::Evaluate(const SensorModel& model, const RayKernel& kernel,
                                     const double* prior, int n, WeightMode mode,
                                     ExpectedEntropyScratch* scratch, EntropySum sum) {
  static const bool kHaveLanes = kernels::UsesAvx512(kernels::Best());
  const bool lanes = sum == EntropySum::kLanes && kHaveLanes;
  KESTREL_THROW_UNLESS(n >= 0 && n <= kernel.size(),
                       "ExpectedEntropy::Evaluate: n = " << n << ", kernel of " << kernel.size());
  KESTREL_THROW_UNLESS(scratch != nullptr && (n == 0 || prior != nullptr),
                       "ExpectedEntropy::Evaluate: null input");
  scratch->Reserve(n);
  const double c0 = model.spurious_density();  // p_rand u
  double* const pi = scratch->pi_.data();
  double* const pbar_before = scratch->pbar_before_.data();  // prod_{i<j} Pbar_i
  double* const pi_prefix = scratch->pi_prefix_.data();      // sum_{i<j} pi_i
  double* const suffix_h = scratch->suffix_h_.data();        // sum_{i>=j} H(P_i)
  double* const s_before = scratch->posterior_.data();       // S_(j-1)
  double* const term = scratch->q_.data();                   // pi_j a_j
  double* const values = scratch->values_.data();
  double* const counts = scratch->counts_.data();

  double pbar = 1.0;
  double pis = 0.0;
  for (int j = 0; j < n; ++j) {
    pbar_before[j] = pbar;
    pi_prefix[j] = pis;
    pi[j] = prior[j] * pbar;  // pi_j
    pis += pi[j];
    pbar *= 1.0 - prior[j];
  }
  pbar_before[n] = pbar;
  pi_prefix[n] = pis;
  const double pi_empty = pbar;
  suffix_h[n] = 0.0;
#if defined(__x86_64__)
  if (lanes) {
    double* const h = scratch->z_.data();
    BinaryEntropiesAvx512(prior, h, n);
    for (int j = n - 1; j >= 0; --j) suffix_h[j] = suffix_h[j + 1] + h[j];
  } else  // NOLINT(readability-misleading-indentation): the #if closes the else's scope
#endif
  {
    for (int j = n - 1; j >= 0; --j) suffix_h[j] = suffix_h[j + 1] + BinaryEntropy(prior[j]);
  }

  RayEntropy out;
  out.prior_entropy_nats = suffix_h[0];
  double weight_sum = 0.0;
  double weighted_h = 0.0;
  int lo_cell = 0;   // cells [0, lo_cell) are in the groups
  int distinct = 0;  // distinct prior values among cells [0, lo_cell)
  bool use_groups = true;
  constexpr int kMaxGroups = 48;
  const double* const g = kernel.g_.data();
  const double* const a = kernel.a_.data();
  for (const RayKernel::Hypothesis& h : kernel.hypotheses_) {
    if (h.k >= n) break;  // a shorter ray: its hypotheses are a prefix of the kernel's
    // (a) q_k from the cells whose window reaches the chord (section 6).
    double q = h.uniform_q;
    if (mode == WeightMode::kChordProbability) {
      const int i_end = std::min(h.g_first + h.g_count, n);
      if (lanes) {
        q += Dot(pi + h.g_first, g + h.g_offset, i_end - h.g_first, true);
      } else {
        for (int i = h.g_first; i < i_end; ++i) q += pi[i] * g[h.g_offset + (i - h.g_first)];
      }
    }
    const int end = std::min(h.end, n);
    const int lo_j = std::min(h.lo, end);
    // (c) cells before lo_j: P'_j = eta p_rand u P_j, summed once per distinct prior value.
    while (lo_cell < lo_j) {
      if (use_groups) {
        const double v = prior[lo_cell];
        int gi = 0;
        while (gi < distinct && values[gi] != v) ++gi;
        if (gi == distinct) {
          if (distinct == kMaxGroups) {
            use_groups = false;
          } else {
            values[gi] = v;
            counts[gi] = 0.0;
            ++distinct;
          }
        }
        if (use_groups) counts[gi] += 1.0;
      }
      ++lo_cell;
    }
    double s = c0 * pi_prefix[lo_j];  // S_(lo-1): every earlier a_i is p_rand u
    for (int j = lo_j; j < end; ++j) {
      const double t = pi[j] * a[h.a_offset + static_cast<size_t>(j - h.lo)];  // pi_j a_j
      s_before[j] = s;
      term[j] = t;
      s += t;
    }
    const double inv_eta = s + pbar_before[end] * h.tail_a;  // eq. (4), completed tail
    const double eta = 1.0 / inv_eta;
    double hk = suffix_h[end];  // (b) beyond z + c sigma: the prior
    if (lanes) {
      double* const post = scratch->z_.data();
      for (int j = lo_j; j < end; ++j) post[j] = eta * (prior[j] * s_before[j] + term[j]);
      hk += SumBinaryEntropy(post + lo_j, nullptr, end - lo_j, true);  // eqs. (2)-(3)
    } else {
      for (int j = lo_j; j < end; ++j) {
        hk += BinaryEntropy(eta * (prior[j] * s_before[j] + term[j]));  // eqs. (2)-(3)
      }
    }
    const double mu = eta * c0;
    if (lanes) {
      double* const post = scratch->z_.data();
      const int count = use_groups ? distinct : lo_j;
      const double* const v = use_groups ? values : prior;
      for (int j = 0; j < count; ++j) post[j] = mu * v[j];
      hk += SumBinaryEntropy(post, use_groups ? counts : nullptr, count, true);
    } else if (use_groups) {
      for (int gi = 0; gi < distinct; ++gi) hk += counts[gi] * BinaryEntropy(mu * values[gi]);
    } else {
      for (int j = 0; j < lo_j; ++j) hk += BinaryEntropy(mu * prior[j]);
    }
    const double w = mode == WeightMode::kChordProbability ? q : inv_eta;  // eq. (8) literal
    weight_sum += w;
    weighted_h += w * hk;
  }
  {
    // "No return": O(n); cells nearer than z_min keep their prior (the mapper's rule).
    double s = 0.0;
    for (int j = 0; j < n; ++j) {
      const double t = pi[j] * kernel.no_return_[static_cast<size_t>(j)];
      s_before[j] = s;
      term[j] = t;
      s += t;
    }
    const double inv_eta = s + pi_empty * model.empty_no_return_probability();  // = q_(n+1)
    const double eta = 1.0 / inv_eta;
    // A sensor whose "no return" is no evidence writes nothing: every cell keeps its prior.
    const int near = model.config().no_return_informs ? std::min(kernel.near_cells_, n) : n;
    double hk = 0.0;
    for (int j = 0; j < near; ++j) hk += BinaryEntropy(prior[j]);
    if (near < n && lanes) {
      double* const post = scratch->z_.data();
      for (int j = near; j < n; ++j) post[j] = eta * (prior[j] * s_before[j] + term[j]);
      hk += SumBinaryEntropy(post + near, nullptr, n - near, true);
    } else if (near < n) {
      for (int j = near; j < n; ++j) hk += BinaryEntropy(eta * (prior[j] * s_before[j] + term[j]));
    }
    weight_sum += inv_eta;
    weighted_h += inv_eta * hk;
  }
  KESTREL_DEMAND(weight_sum > 0.0);
  out.expected_entropy_nats = weighted_h / weight_sum;  // eq. (7)
  return out;
}

void GainConfig::Validate() const {
  KESTREL_THROW_UNLESS(!sensors.empty(), "gain sensors: empty, accepted at least one sensor");
  for (size_t s = 0; s < sensors.size(); ++s) {
    sensors[s].model.Validate();
    KESTREL_THROW_UNLESS(
        sensors[s].horizontal_fov_rad > 0.0 && sensors[s].horizontal_fov_rad <= 2.0 * M_PI,
        "gain sensors[" << s << "].horizontal_fov_rad = " << sensors[s].horizontal_fov_rad
                        << ", accepted (0, 2 pi]");
    KESTREL_THROW_UNLESS(std::isfinite(sensors[s].yaw_offset_rad),
                         "gain sensors[" << s << "].yaw_offset_rad not finite");
  }
  KESTREL_THROW_UNLESS(rays_per_revolution >= 4 && rays_per_revolution <= 36000,
                       "rays_per_revolution = " << rays_per_revolution << ", accepted [4, 36000]");
}

GainEvaluator::GainEvaluator(const GainConfig& config) : config_(config) {
  config_.Validate();
  for (const GainSensor& s : config_.sensors) models_.emplace_back(s.model);
  cache_.assign(config_.sensors.size() * static_cast<size_t>(config_.rays_per_revolution),
                std::numeric_limits<double>::quiet_NaN());
  kernels_.resize(cache_.size());
}

std::vector<int> GainEvaluator::RayIndices(int sensor, double yaw_rad) const {
  const GainSensor& s = config_.sensors[static_cast<size_t>(sensor)];
  const int r = config_.rays_per_revolution;
  const double step = 2.0 * M_PI / r;
  const double centre = yaw_rad + s.yaw_offset_rad;
  const long first =
      static_cast<long>(std::ceil((centre - 0.5 * s.horizontal_fov_rad) / step - 1e-9));
  long last = static_cast<long>(std::floor((centre + 0.5 * s.horizontal_fov_rad) / step + 1e-9));
  if (last - first + 1 > r) last = first + r - 1;  // a full circle: each direction once
  std::vector<int> out;
  for (long m = first; m <= last; ++m) out.push_back(static_cast<int>(((m % r) + r) % r));
  return out;
}

double GainEvaluator::RayGain(const GridMap2D& map, int sensor, const Eigen::Vector2d& position_m,
                              double angle_rad) {
  return EvaluateRay(map, sensor, position_m, angle_rad, -1, 0.0, nullptr);
}

double GainEvaluator::EvaluateRay(const GridMap2D& map, int sensor,
                                  const Eigen::Vector2d& position_m, double angle_rad,
                                  int kernel_slot, double saturation_p, double* excess) {
  const SensorModel& model = models_[static_cast<size_t>(sensor)];
  double cx = std::cos(angle_rad);
  double sy = std::sin(angle_rad);
  if (std::abs(cx) < 1e-15) cx = 0.0;  // exact axis directions
  if (std::abs(sy) < 1e-15) sy = 0.0;
  const Eigen::Vector2d u = Eigen::Vector2d(cx, sy).normalized();
  const int n = CastRay2D(map, position_m, u, model.config().z_max_m, &ray_);
  if (prior_.size() < static_cast<size_t>(n)) prior_.resize(2 * static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    prior_[static_cast<size_t>(j)] =
        map.values[static_cast<size_t>(ray_.index[static_cast<size_t>(j)])];
  }
  RayKernel* kernel = nullptr;
  if (config_.method == GainMethod::kFast && kernel_slot >= 0) {
    // The chords depend on the direction and on the origin's place inside its cell only, so
    // positions at the same offset (every candidate lattice point) share one kernel.
    kernel = &kernels_[static_cast<size_t>(kernel_slot)];
    if (!kernel->Matches(ray_.entry_m.data(), ray_.exit_m.data(), ray_.distance_m.data(), n)) {
      kernel->Build(model, ray_.entry_m.data(), ray_.exit_m.data(), ray_.distance_m.data(), n);
      ++kernels_built_;
    }
  }
  const auto gain_of = [&](const double* prior) {
    if (kernel != nullptr) {
      return ExpectedEntropy::Evaluate(model, *kernel, prior, n, config_.weight_mode, &scratch_)
          .gain_nats();
    }
    return ExpectedEntropy::Compute(model, ray_.entry_m.data(), ray_.exit_m.data(),
                                    ray_.distance_m.data(), prior, n, config_.weight_mode,
                                    config_.method, &scratch_)
        .gain_nats();
  };
  const double gain = gain_of(prior_.data());
  if (excess != nullptr) {
    // The same ray on the saturated map: P_sat where P <= 0.5, else 1 - P_sat.
    const double hi = 1.0 - saturation_p;
    bool saturated = true;
    for (int j = 0; j < n && saturated; ++j) {
      const double p = prior_[static_cast<size_t>(j)];
      saturated = p == saturation_p || p == hi;
    }
    if (saturated) {
      *excess = 0.0;
    } else {
      for (int j = 0; j < n; ++j) {
        double& p = prior_[static_cast<size_t>(j)];
        p = p <= 0.5 ? saturation_p : hi;
      }
      *excess = gain - gain_of(prior_.data());
    }
  }
  return gain;
}

std::vector<double> GainEvaluator::HeadingGains(const GridMap2D& map,
                                                const Eigen::Vector2d& position_m, int n_yaw,
                                                double yaw0_rad, GainStats* stats,
                                                double saturation_p, std::vector<double>* excess,
                                                const GridMap2D* planar_map) {
  KESTREL_THROW_UNLESS(n_yaw >= 1, "HeadingGains: n_yaw = " << n_yaw << ", accepted >= 1");
  KESTREL_THROW_UNLESS(
      planar_map == nullptr ||
          (planar_map->width == map.width && planar_map->height == map.height &&
           planar_map->resolution_m == map.resolution_m && planar_map->origin_m == map.origin_m),
      "HeadingGains: the planar map's lattice differs from the map's");
  KESTREL_THROW_UNLESS(excess == nullptr || (saturation_p > 0.0 && saturation_p < 0.5),
                       "HeadingGains: saturation_p = " << saturation_p << ", accepted (0, 0.5)");
  std::fill(cache_.begin(), cache_.end(), std::numeric_limits<double>::quiet_NaN());
  const int r = config_.rays_per_revolution;
  std::vector<double> gains(static_cast<size_t>(n_yaw), 0.0);
  if (excess != nullptr) excess->assign(static_cast<size_t>(n_yaw), 0.0);
  if (excess_cache_.size() != cache_.size()) excess_cache_.resize(cache_.size());
  for (int m = 0; m < n_yaw; ++m) {
    const double yaw = yaw0_rad + 2.0 * M_PI * m / n_yaw;
    long rays = 0;
    for (int s = 0; s < static_cast<int>(config_.sensors.size()); ++s) {
      for (int idx : RayIndices(s, yaw)) {
        const size_t at =
            static_cast<size_t>(s) * static_cast<size_t>(r) + static_cast<size_t>(idx);
        double& cached = cache_[at];
        if (std::isnan(cached)) {
          const int slot = s * r + idx;
          const long built_before = kernels_built_;
          const bool layer =
              planar_map != nullptr && config_.sensors[static_cast<size_t>(s)].planar;
          cached = EvaluateRay(layer ? *planar_map : map, s, position_m, 2.0 * M_PI * idx / r,
                               config_.cache_kernels ? slot : -1, saturation_p,
                               excess != nullptr ? &excess_cache_[at] : nullptr);
          if (stats != nullptr) {
            stats->kernels_built += kernels_built_ - built_before;
            ++stats->rays_cast;
            stats->ray_cells += ray_.size;
          }
        }
        gains[static_cast<size_t>(m)] += cached;  // eq. (10): sum of I_ray over the scan
        if (excess != nullptr) (*excess)[static_cast<size_t>(m)] += excess_cache_[at];
        ++rays;
      }
    }
    if (stats != nullptr) stats->rays_per_pose = rays;
  }
  return gains;
}

double GainEvaluator::PoseGain(const GridMap2D& map, const Eigen::Vector2d& position_m,
                               double yaw_rad) {
  double gain = 0.0;
  for (int s = 0; s < static_cast<int>(config_.sensors.size()); ++s) {
    for (int idx : RayIndices(s, yaw_rad)) {
      const int r = config_.rays_per_revolution;
      gain += EvaluateRay(map, s, position_m, 2.0 * M_PI * idx / r,
                          config_.cache_kernels ? s * r + idx : -1, 0.0, nullptr);
    }
  }
  return gain;
}

}  // namespace kestrel

#include "mapping/occupancy_updater.h"

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "common/check.h"
#include "mapping/avx512.h"

namespace kestrel {
namespace {
// The bit pattern of a float (a changed cell is a changed bit pattern, as Hash sees it).
uint32_t BitsOf(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  return bits;
}
float Logit(double p) { return static_cast<float>(std::log(p / (1.0 - p))); }
}  // namespace

ExactBayesUpdater::ExactBayesUpdater(const OccupancyLimits& limits, int capacity,
                                     double resolution_m)
    : limits_(limits),
      diagonal_m_(std::sqrt(3.0) * resolution_m),
      scratch_(capacity),
      lane_cells_(static_cast<size_t>(capacity)),
      lane_priors_(static_cast<size_t>(capacity)),
      lane_posteriors_(static_cast<size_t>(capacity)) {
  limits_.Validate();
}

double ExactBayesUpdater::CastLength(const SensorModel& model, const Reading& reading) const {
  const double z_max = model.config().z_max_m;
  if (reading.kind != ReadingKind::kReturn) return z_max;
  // Cells with d_k <= z + c sigma have entry <= z + c sigma and a chord of at most sqrt(3)
  // alpha, so casting this far gives them their full chords (their d_k unchanged); the factor
  // keeps a corner-to-corner chord clear of rounding.
  return std::min(z_max, model.GaussianReach(reading.z_m) + diagonal_m_ * (1.0 + 1e-9));
}

int ExactBayesUpdater::UpdateRay(const SensorModel& model, const Reading& reading,
                                 const RayCells& ray, float* const* cells, uint64_t* cells_written,
                                 int* changed) {
  return Update(
      model, reading, ray.distance_m.data(), ray.size,
      ray.has_likelihood ? ray.likelihood.data() : nullptr,
      [cells](int k) -> float& { return *cells[k]; }, cells_written, changed);
}

int ExactBayesUpdater::UpdateRayLinear(const SensorModel& model, const Reading& reading,
                                       const RayCells& ray, float* base, uint64_t* cells_written,
                                       int* changed) {
  KESTREL_DEMAND(ray.has_linear_index);
  const int32_t* const linear = ray.linear_index.data();
  return Update(
      model, reading, ray.distance_m.data(), ray.size,
      ray.has_likelihood ? ray.likelihood.data() : nullptr,
      [base, linear](int k) -> float& { return base[linear[k]]; }, cells_written, changed);
}

void ExactBayesUpdater::PrecomputeBatch(const SensorModel& model, const Reading* readings,
                                        lanes::Isa isa, RayBatch* batch) const {
  batch->has_likelihood = model.FillLikelihoods(readings, batch->count, batch->distance_m.data(),
                                                batch->longest, batch->likelihood.data(), isa);
}

#if defined(__x86_64__)
namespace {

KESTREL_AVX512_BEGIN
// The write step of ExactBayesUpdater::Update for n cells, eight at a time: clamps posterior[i]
// (ClampProbability as min then max with the scalar code's operand order, so ties and values
// agree), converts it to float, stores it at base[cells[i]] (a scatter: a ray never lists a cell
// twice, so the order of the stores does not matter), and lists the cells whose stored value
// changed, first + i ascending, in changed[0 .. returned count); priors[i] is the value stored
// before (compared bit for bit).
[[KESTREL_AVX512]] int StorePosteriorsAvx512(const double* posterior, const int32_t* cells,
                                             const float* priors, int first, int n, double p_min,
                                             float* base, int* changed) {
  const __m512d lower = _mm512_set1_pd(p_min);
  const __m512d upper = _mm512_set1_pd(1.0 - p_min);
  const __m256i step = _mm256_set1_epi32(8);
  __m256i k = _mm256_add_epi32(_mm256_set1_epi32(first), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  int m = 0;
  for (int i = 0; i < n; i += 8) {
    const __mmask8 live = n - i >= 8 ? __mmask8{0xFF} : static_cast<__mmask8>((1u << (n - i)) - 1);
    const __m512d p = _mm512_maskz_loadu_pd(live, posterior + i);
    // upper < p ? upper : p, then below_upper < p_min ? p_min : below_upper.
    const __m512d clamped = _mm512_max_pd(lower, _mm512_min_pd(upper, p));
    const __m256 stored = _mm512_cvtpd_ps(clamped);
    const __m256i stored_bits = _mm256_castps_si256(stored);
    const __m256i prior_bits = _mm256_maskz_loadu_epi32(live, priors + i);
    const __mmask8 differ = _mm256_mask_cmpneq_epi32_mask(live, stored_bits, prior_bits);
    _mm256_mask_compressstoreu_epi32(changed + m, differ, k);
    m += __builtin_popcount(differ);
    const __m256i where = _mm256_maskz_loadu_epi32(live, cells + i);
    _mm256_mask_i32scatter_ps(base, live, where, stored, 4);
    k = _mm256_add_epi32(k, step);
  }
  return m;
}
KESTREL_AVX512_END

}  // namespace
#endif

int ExactBayesUpdater::UpdateBatchLane(const SensorModel& model, const Reading& reading,
                                       const RayBatch& batch, int lane, float* base,
                                       uint64_t* cells_written, int* changed) {
  const int n = batch.size[lane];
  const int32_t* const linear = batch.linear_index.data() + lane;
  const LaneView distance{batch.distance_m.data() + lane};
  const LaneView likelihood{batch.has_likelihood ? batch.likelihood.data() + lane : nullptr};
#if defined(__x86_64__)
  if (batch.isa == lanes::Isa::kAvx512) {
    KESTREL_DEMAND(n <= scratch_.capacity());
    int32_t* const cells = lane_cells_.data();
    float* const priors = lane_priors_.data();
    double* const posteriors = lane_posteriors_.data();
    // Section 4 with the cells read once (their indices and values kept in order), then the
    // write step for the cells written, eight at a time (Update does it cell by cell).
    const ExactUpdateResult r = ExactUpdate::Apply(
        model, reading, distance, n,
        [&](int k) {
          const int32_t cell = linear[static_cast<ptrdiff_t>(k) * lanes::kLanes];
          cells[k] = cell;
          priors[k] = base[cell];
          return static_cast<double>(priors[k]);
        },
        [posteriors](int k, double posterior) { posteriors[k] = posterior; }, &scratch_,
        likelihood);
    *cells_written += static_cast<uint64_t>(r.count);
    const size_t first = static_cast<size_t>(r.first);
    return StorePosteriorsAvx512(posteriors + first, cells + first, priors + first, r.first,
                                 r.count, limits_.p_min, base, changed);
  }
#endif
  return Update(
      model, reading, distance, n, likelihood,
      [base, linear](int k) -> float& {
        return base[linear[static_cast<ptrdiff_t>(k) * lanes::kLanes]];
      },
      cells_written, changed);
}

template <class Distance, class Likelihood, class CellAt>
int ExactBayesUpdater::Update(const SensorModel& model, const Reading& reading,
                              const Distance& distance_m, int n, Likelihood likelihood,
                              const CellAt& cell_at, uint64_t* cells_written, int* changed) {
  KESTREL_DEMAND(n <= scratch_.capacity());
  const double p_min = limits_.p_min;
  int m = 0;
  const ExactUpdateResult r = ExactUpdate::Apply(
      model, reading, distance_m, n, [&cell_at](int k) { return static_cast<double>(cell_at(k)); },
      [&](int k, double posterior) {
        // docs/algorithms.md §1.2: clamp to [P_min, 1 - P_min] after each update. Branch-free:
        // a cell held at its value (typically a free cell at the clamp) is rewritten unchanged
        // and not reported.
        const float stored = static_cast<float>(ClampProbability(posterior, p_min));
        float& cell = cell_at(k);
        changed[m] = k;
        m += BitsOf(stored) != BitsOf(cell) ? 1 : 0;  // no NaN here: compare the bits
        cell = stored;
      },
      &scratch_, likelihood);
  *cells_written += static_cast<uint64_t>(r.count);
  return m;
}

void ExactBayesUpdater::PrecomputeRay(const SensorModel& model, const Reading& reading,
                                      RayCells* ray) const {
  if (reading.kind == ReadingKind::kInvalid) return;
  ExactUpdate::ForwardLikelihoods(model, reading, ray->distance_m.data(), ray->size,
                                  ray->likelihood.data());
  ray->has_likelihood = true;
}

void LogOddsConfig::Validate() const {
  KESTREL_THROW_UNLESS(p_hit > 0.5 && p_hit < 1.0,
                       "log-odds p_hit = " << p_hit << ", accepted (0.5, 1)");
  KESTREL_THROW_UNLESS(p_miss > 0.0 && p_miss < 0.5,
                       "log-odds p_miss = " << p_miss << ", accepted (0, 0.5)");
  KESTREL_THROW_UNLESS(p_clamp_min > 0.0 && p_clamp_min <= p_unknown && p_unknown <= p_clamp_max &&
                           p_clamp_max < 1.0,
                       "log-odds clamps: p_clamp_min = " << p_clamp_min
                                                         << ", p_unknown = " << p_unknown
                                                         << ", p_clamp_max = " << p_clamp_max
                                                         << ", accepted 0 < min <= unknown <= "
                                                            "max < 1");
}

LogOddsUpdater::LogOddsUpdater(const LogOddsConfig& config) : config_(config) {
  config_.Validate();
  hit_ = Logit(config_.p_hit);
  miss_ = Logit(config_.p_miss);
  min_ = Logit(config_.p_clamp_min);
  max_ = Logit(config_.p_clamp_max);
  initial_ = Logit(config_.p_unknown);
}

double LogOddsUpdater::CastLength(const SensorModel& model, const Reading& reading) const {
  return reading.kind == ReadingKind::kReturn ? reading.z_m : model.config().z_max_m;
}

int LogOddsUpdater::UpdateRay(const SensorModel& /*model*/, const Reading& reading,
                              const RayCells& ray, float* const* cells, uint64_t* cells_written,
                              int* changed) {
  return Update(
      reading, ray.size, ray.left_bounds, [cells](int k) -> float& { return *cells[k]; },
      cells_written, changed);
}

int LogOddsUpdater::UpdateRayLinear(const SensorModel& /*model*/, const Reading& reading,
                                    const RayCells& ray, float* base, uint64_t* cells_written,
                                    int* changed) {
  KESTREL_DEMAND(ray.has_linear_index);
  const int32_t* const linear = ray.linear_index.data();
  return Update(
      reading, ray.size, ray.left_bounds,
      [base, linear](int k) -> float& { return base[linear[k]]; }, cells_written, changed);
}

int LogOddsUpdater::UpdateBatchLane(const SensorModel& /*model*/, const Reading& reading,
                                    const RayBatch& batch, int lane, float* base,
                                    uint64_t* cells_written, int* changed) {
  const int32_t* const linear = batch.linear_index.data() + lane;
  return Update(
      reading, batch.size[lane], batch.left_bounds[lane],
      [base, linear](int k) -> float& {
        return base[linear[static_cast<ptrdiff_t>(k) * lanes::kLanes]];
      },
      cells_written, changed);
}

template <class CellAt>
int LogOddsUpdater::Update(const Reading& reading, int n, bool left_bounds, const CellAt& cell_at,
                           uint64_t* cells_written, int* changed) {
  int m = 0;
  for (int k = 0; k < n; ++k) {
    float& cell = cell_at(k);
    const float prior = cell;
    // The end point's cell is the last one cast for a return: a hit (OctoMap updateNode(hit)).
    // A ray that ended at the map limits never reached its end point: all misses.
    const bool hit = reading.kind == ReadingKind::kReturn && k == n - 1 && !left_bounds;
    const float stored = std::clamp(prior + (hit ? hit_ : miss_), min_, max_);
    changed[m] = k;
    m += stored != prior ? 1 : 0;
    cell = stored;
  }
  *cells_written += static_cast<uint64_t>(n);
  return m;
}

}  // namespace kestrel

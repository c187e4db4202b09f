#include "mapping/occupancy_updater.h"

#include <algorithm>

#include "common/check.h"

namespace kestrel {

ExactBayesUpdater::ExactBayesUpdater(const OccupancyLimits& limits, int capacity,
                                     double resolution_m)
    : limits_(limits), diagonal_m_(std::sqrt(3.0) * resolution_m), scratch_(capacity) {
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

double ExactBayesUpdater::UpdateRay(const SensorModel& model, const Reading& reading,
                                    const RayCells& ray, float* const* cells,
                                    uint64_t* cells_written) {
  KESTREL_DEMAND(ray.size <= scratch_.capacity());
  double delta_entropy = 0.0;
  const double p_min = limits_.p_min;
  const ExactUpdateResult r = ExactUpdate::Apply(
      model, reading, ray.distance_m.data(), ray.size,
      [cells](int k) { return static_cast<double>(*cells[k]); },
      [&](int k, double posterior) {
        // ALGORITHMS.md section 1: clamp to [P_min, 1 - P_min] after each update.
        const float stored = static_cast<float>(ClampProbability(posterior, p_min));
        const float prior = *cells[k];
        // Section 5: add the change of every written cell (of the values actually stored). A
        // cell that stays at its value (typically a free cell held at the clamp) changes nothing.
        if (stored != prior) {
          delta_entropy += BinaryEntropy(stored) - BinaryEntropy(prior);
          *cells[k] = stored;
        }
      },
      &scratch_, ray.has_likelihood ? ray.likelihood.data() : nullptr);
  *cells_written += static_cast<uint64_t>(r.count);
  return delta_entropy;
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

namespace {
float Logit(double p) { return static_cast<float>(std::log(p / (1.0 - p))); }
}  // namespace

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

double LogOddsUpdater::UpdateRay(const SensorModel& /*model*/, const Reading& reading,
                                 const RayCells& ray, float* const* cells,
                                 uint64_t* cells_written) {
  const int n = ray.size;
  double delta_entropy = 0.0;
  for (int k = 0; k < n; ++k) {
    const float prior = *cells[k];
    // The end point's cell is the last one cast for a return: a hit (OctoMap updateNode(hit)).
    // A ray that ended at the map limits never reached its end point: all misses.
    const bool hit = reading.kind == ReadingKind::kReturn && k == n - 1 && !ray.left_bounds;
    const float stored = std::clamp(prior + (hit ? hit_ : miss_), min_, max_);
    if (stored != prior) {
      delta_entropy += BinaryEntropy(ProbabilityOf(stored)) - BinaryEntropy(ProbabilityOf(prior));
      *cells[k] = stored;
    }
  }
  *cells_written += static_cast<uint64_t>(n);
  return delta_entropy;
}

}  // namespace kestrel

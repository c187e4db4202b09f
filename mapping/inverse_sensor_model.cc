#include "mapping/inverse_sensor_model.h"

namespace kestrel {

void ExactUpdate::CheckInput(const Reading& reading, int n,
                             const InverseSensorModelScratch* scratch) {
  KESTREL_THROW_UNLESS(reading.kind != ReadingKind::kInvalid,
                       "ComputeExactPosteriors: invalid readings must be dropped by the caller");
  KESTREL_THROW_UNLESS(scratch != nullptr && n >= 0 && n <= scratch->capacity(),
                       "ComputeExactPosteriors: n = " << n << ", accepted [0, scratch capacity]");
}

int ExactUpdate::ForwardLikelihoods(const SensorModel& model, const Reading& reading,
                                    const double* distance_m, int n, double* likelihood) {
  KESTREL_THROW_UNLESS(reading.kind != ReadingKind::kInvalid,
                       "ForwardLikelihoods: invalid readings must be dropped by the caller");
  if (reading.kind == ReadingKind::kReturn) {
    const double lo = reading.z_m - reading.below_m;
    const int end = ReturnCellsEnd(model, reading, distance_m, n);  // same cut as Apply
    int k = 0;
    // The leading cells outside the Gaussian window: a_k is the spurious term alone.
    for (; k < end && model.SpuriousOnly(reading, distance_m[k]); ++k) {
      likelihood[k] = model.spurious_density();
    }
    // The same values as Apply's (docs/algorithms.md §3.8; the plain a_k without a band).
    const ReturnLikelihoodEvaluator a_k = model.ReturnEvaluator();
    const double band_scale = model.BandScale(reading);
    for (; k < end; ++k) likelihood[k] = a_k.Banded(lo, reading.z_m, band_scale, distance_m[k]);
    return end;
  }
  for (int k = 0; k < n; ++k) likelihood[k] = model.NoReturnProbability(distance_m[k]);
  return n;
}

ExactUpdateResult ExactUpdate::ComputeExactPosteriors(const SensorModel& model,
                                                      const Reading& reading,
                                                      const double* distance_m, const double* prior,
                                                      int n, double* posterior,
                                                      InverseSensorModelScratch* scratch) {
  return Apply(
      model, reading, distance_m, n, [prior](int k) { return prior[k]; },
      [posterior](int k, double p) { posterior[k] = p; }, scratch);
}

}  // namespace kestrel

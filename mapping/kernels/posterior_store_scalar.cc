// The scalar posterior stores of the exact update (kernels.h, StorePosteriorsFn and
// StorePosteriorsAtFn; ExactBayesUpdater::UpdateBatchLane).
#include <cstdint>

#include "mapping/kernels/kernels.h"
#include "mapping/kernels/posterior_store.h"

namespace kestrel::kernels {

int StorePosteriorsScalar(const double* scale, bool per_cell, const float* priors,
                          const int32_t* cells, int first, int n, double p_min, float* base,
                          int* changed) {
  return StoreCells(
      scale, per_cell, priors, first, 0, n, p_min,
      [base, cells](int i) -> float& { return base[cells[i]]; }, changed, 0);
}

int StorePosteriorsAtScalar(const double* scale, bool per_cell, const float* priors,
                            float* const* cells, int first, int n, double p_min, int* changed) {
  return StoreCells(
      scale, per_cell, priors, first, 0, n, p_min, [cells](int i) -> float& { return *cells[i]; },
      changed, 0);
}

}  // namespace kestrel::kernels

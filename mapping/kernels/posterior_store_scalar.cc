// The scalar posterior stores of the exact update (kernels.h, StorePosteriorsFn and
// StorePosteriorsAtFn; ExactBayesUpdater::UpdateBatchLane).
#include <cstdint>

#include "mapping/kernels/kernels.h"
#include "mapping/kernels/posterior_store.h"

namespace kestrel::kernels {

int StorePosteriorsScalar(const double* posterior, const int32_t* cells, const float* priors,
                          int first, int n, double p_min, float* base, int* changed) {
  return StoreCells(
      posterior, priors, first, 0, n, p_min,
      [base, cells](int i) -> float& { return base[cells[i]]; }, changed, 0);
}

int StorePosteriorsAtScalar(const double* posterior, float* const* cells, const float* priors,
                            int first, int n, double p_min, int* changed) {
  return StoreCells(
      posterior, priors, first, 0, n, p_min, [cells](int i) -> float& { return *cells[i]; },
      changed, 0);
}

}  // namespace kestrel::kernels

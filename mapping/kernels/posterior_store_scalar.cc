// The scalar posterior stores of the exact update (kernels.h, StorePosteriorsFn and
// StorePosteriorsAtFn; ExactBayesUpdater::UpdateBatchLane).
#include <cstdint>
#include <cstring>

#include "mapping/inverse_sensor_model.h"
#include "mapping/kernels/kernels.h"

namespace kestrel::kernels {

namespace {
// The bit pattern of a float (a changed cell is a changed bit pattern, as Hash sees it).
uint32_t BitsOf(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  return bits;
}

// The write step for n cells, cell i's value at cell_at(i) (a float&).
template <class CellAt>
int Store(const double* posterior, const float* priors, int first, int n, double p_min,
          const CellAt& cell_at, int* changed) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    // docs/algorithms.md §1.2: clamp to [P_min, 1 - P_min] after each update. Branch-free:
    // a cell held at its value (typically a free cell at the clamp) is rewritten unchanged
    // and not reported.
    const float stored = static_cast<float>(ClampProbability(posterior[i], p_min));
    changed[m] = first + i;
    m += BitsOf(stored) != BitsOf(priors[i]) ? 1 : 0;  // no NaN here: compare the bits
    cell_at(i) = stored;
  }
  return m;
}
}  // namespace

int StorePosteriorsScalar(const double* posterior, const int32_t* cells, const float* priors,
                          int first, int n, double p_min, float* base, int* changed) {
  return Store(
      posterior, priors, first, n, p_min, [base, cells](int i) -> float& { return base[cells[i]]; },
      changed);
}

int StorePosteriorsAtScalar(const double* posterior, float* const* cells, const float* priors,
                            int first, int n, double p_min, int* changed) {
  return Store(
      posterior, priors, first, n, p_min, [cells](int i) -> float& { return *cells[i]; }, changed);
}

}  // namespace kestrel::kernels

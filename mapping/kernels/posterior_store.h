#pragma once
/// @file
/// The write step of the exact update, cell by cell (kernels.h, StorePosteriorsFn): the scalar
/// kernels (posterior_store_scalar.cc) and the vector kernels' last cells
/// (posterior_store-inl.h). Internal to mapping/.

#include <cstdint>
#include <cstring>

#include "mapping/inverse_sensor_model.h"

namespace kestrel::kernels {

// The bit pattern of a float (a changed cell is a changed bit pattern, as Hash sees it).
inline uint32_t BitsOf(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, sizeof(bits));
  return bits;
}

// The write step for cells i in [begin, n), cell i's value at cell_at(i) (a float&): the
// posterior scale[per_cell ? i : 0] * priors[i] (kernels.h, StorePosteriorsFn) clamped, stored as
// float, and first + i listed in changed[m ...] where the stored bits differ from priors[i].
// Returns m plus the cells listed.
template <class CellAt>
int StoreCells(const double* scale, bool per_cell, const float* priors, int first, int begin, int n,
               double p_min, const CellAt& cell_at, int* changed, int m) {
  for (int i = begin; i < n; ++i) {
    const double posterior = scale[per_cell ? i : 0] * static_cast<double>(priors[i]);
    // docs/algorithms.md §1.2: clamp to [P_min, 1 - P_min] after each update. Branch-free:
    // a cell held at its value (typically a free cell at the clamp) is rewritten unchanged
    // and not reported.
    const float stored = static_cast<float>(ClampProbability(posterior, p_min));
    changed[m] = first + i;
    m += BitsOf(stored) != BitsOf(priors[i]) ? 1 : 0;  // no NaN here: compare the bits
    cell_at(i) = stored;
  }
  return m;
}

}  // namespace kestrel::kernels

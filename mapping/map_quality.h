#pragma once
/// @file
/// Map quality against ground truth (docs/algorithms.md §12.2), over the observable cells:
///  - known fraction: known cells / observable cells, where a cell is known when P < P_init/2 or
///    P > 0.5, or, for maps whose lower clamp is above P_init/2 (OctoMap's 0.12), when it has
///    been observed at all (pass an `observed` mask);
///  - accuracy: fraction of the known cells whose (P > 0.5) agrees with the truth;
///  - Brier score: mean of (P - truth)^2 over the observable cells;
///  - ROC AUC of P against the truth over the observable cells (Mann-Whitney: the probability
///    that a random occupied cell scores above a random free one, ties counting 1/2).
/// Undefined values (no known cell, a class without cells) are NaN.

#include <cstdint>
#include <vector>

#include "mapping/occupancy_map.h"

namespace kestrel {

/// The four numbers of section 10 and the counts behind them.
struct MapQuality {
  size_t observable_cells{0};  ///< cells in the observable mask
  size_t known_cells{0};       ///< observable cells that are known
  double known_fraction{0.0};  ///< known / observable
  double accuracy{0.0};        ///< known cells whose P > 0.5 matches the truth, fraction
  double brier{0.0};           ///< mean (P - truth)^2 over observable cells
  double roc_auc{0.0};         ///< area under the ROC curve of P against the truth
};

/// Computes the map quality. All arrays are per cell in the same order and of the same size;
/// truth and masks are 0/1. `observed` may be null (then the P_init/2 rule applies).
/// @throws std::invalid_argument on size mismatch or p_init outside (0, 1).
[[nodiscard]] MapQuality ComputeMapQuality(const std::vector<double>& probability,
                                           const std::vector<uint8_t>& truth_occupied,
                                           const std::vector<uint8_t>& observable, double p_init,
                                           const std::vector<uint8_t>* observed = nullptr);

/// P of every cell of a dense map, in its linear order (x fastest).
[[nodiscard]] std::vector<double> ProbabilitiesOf(const DenseOccupancyMap& map);
/// 1 for every cell of a dense map whose value differs from the untouched value.
[[nodiscard]] std::vector<uint8_t> ObservedMaskOf(const DenseOccupancyMap& map);

}  // namespace kestrel

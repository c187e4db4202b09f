#include "mapping/map_quality.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "common/check.h"

namespace kestrel {

MapQuality ComputeMapQuality(const std::vector<double>& probability,
                             const std::vector<uint8_t>& truth_occupied,
                             const std::vector<uint8_t>& observable, double p_init,
                             const std::vector<uint8_t>* observed) {
  const size_t n = probability.size();
  KESTREL_THROW_UNLESS(truth_occupied.size() == n && observable.size() == n &&
                           (observed == nullptr || observed->size() == n),
                       "ComputeMapQuality: array sizes differ ("
                           << n << " probabilities, " << truth_occupied.size() << " truth, "
                           << observable.size() << " observable)");
  KESTREL_THROW_UNLESS(p_init > 0.0 && p_init < 1.0,
                       "ComputeMapQuality: p_init = " << p_init << ", accepted (0, 1)");
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  MapQuality q;
  size_t correct = 0;
  double brier_sum = 0.0;
  std::vector<std::pair<double, bool>> scored;
  scored.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    if (!observable[i]) continue;
    ++q.observable_cells;
    const double p = probability[i];
    const bool truth = truth_occupied[i] != 0;
    const bool known = observed != nullptr ? (*observed)[i] != 0 : (p < 0.5 * p_init || p > 0.5);
    if (known) {
      ++q.known_cells;
      correct += (p > 0.5) == truth;
    }
    brier_sum += (p - (truth ? 1.0 : 0.0)) * (p - (truth ? 1.0 : 0.0));
    scored.emplace_back(p, truth);
  }
  if (q.observable_cells == 0) {
    q.known_fraction = q.accuracy = q.brier = q.roc_auc = kNan;
    return q;
  }
  q.known_fraction = static_cast<double>(q.known_cells) / static_cast<double>(q.observable_cells);
  q.accuracy =
      q.known_cells > 0 ? static_cast<double>(correct) / static_cast<double>(q.known_cells) : kNan;
  q.brier = brier_sum / static_cast<double>(q.observable_cells);
  // Mann-Whitney U with average ranks for ties.
  std::sort(scored.begin(), scored.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  double rank_sum_positive = 0.0;
  size_t positives = 0;
  for (size_t i = 0; i < scored.size();) {
    size_t j = i;
    while (j < scored.size() && scored[j].first == scored[i].first) ++j;
    const double average_rank = 0.5 * static_cast<double>(i + 1 + j);  // ranks i+1 .. j
    for (size_t k = i; k < j; ++k) {
      if (scored[k].second) {
        rank_sum_positive += average_rank;
        ++positives;
      }
    }
    i = j;
  }
  const size_t negatives = scored.size() - positives;
  if (positives == 0 || negatives == 0) {
    q.roc_auc = kNan;
  } else {
    const double np = static_cast<double>(positives);
    q.roc_auc = (rank_sum_positive - np * (np + 1.0) / 2.0) / (np * static_cast<double>(negatives));
  }
  return q;
}

std::vector<double> ProbabilitiesOf(const DenseOccupancyMap& map) {
  std::vector<double> p(map.grid().size());
  for (size_t i = 0; i < p.size(); ++i) p[i] = map.updater().ProbabilityOf(map.grid().values()[i]);
  return p;
}

std::vector<uint8_t> ObservedMaskOf(const DenseOccupancyMap& map) {
  std::vector<uint8_t> m(map.grid().size());
  const float untouched = map.updater().initial_value();
  for (size_t i = 0; i < m.size(); ++i) m[i] = map.grid().values()[i] != untouched;
  return m;
}

}  // namespace kestrel

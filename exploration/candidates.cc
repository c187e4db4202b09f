#include "exploration/candidates.h"

#include <cmath>

#include "common/check.h"

namespace kestrel {

void CandidateConfig::Validate() const {
  KESTREL_THROW_UNLESS(lattice_step >= 1, "lattice_step = " << lattice_step << ", accepted >= 1");
  KESTREL_THROW_UNLESS(n_yaw >= 1 && n_yaw <= 360, "n_yaw = " << n_yaw << ", accepted [1, 360]");
  KESTREL_THROW_UNLESS(d_max_epsilon >= 0.0 && std::isfinite(d_max_epsilon),
                       "d_max_epsilon = " << d_max_epsilon << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(d_fixed_m > 0.0 && std::isfinite(d_fixed_m),
                       "d_fixed_m = " << d_fixed_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(end_gain_nats >= 0.0 && std::isfinite(end_gain_nats),
                       "end_gain_nats = " << end_gain_nats << ", accepted [0, inf)");
}

double Bump(double d_m, double d_max_m) {
  KESTREL_ASSERT(d_max_m > 0.0);
  if (!(std::abs(d_m) < d_max_m)) return 0.0;
  const double r = d_m / d_max_m;
  return std::exp(1.0 - 1.0 / (1.0 - r * r));  // eq. (17)
}

double DMax(const CandidateConfig& config, double max_distance_m) {
  const double scaled = (1.0 + config.d_max_epsilon) * max_distance_m;
  double d =
      config.d_max_policy == DMaxPolicy::kSimulation ? scaled : std::max(config.d_fixed_m, scaled);
  if (!(d > 0.0)) d = 1e-9;
  // epsilon = 0 with kSimulation gives the farthest cell weight 0 (the paper's form).
  return d;
}

std::vector<int> CandidateCells(const DistanceField& field, const CandidateConfig& config) {
  std::vector<int> cells;
  for (int y = 0; y < field.height; y += config.lattice_step) {
    for (int x = 0; x < field.width; x += config.lattice_step) {
      const int i = x + field.width * y;
      if (config.exclude_vehicle_cell && i == field.start) continue;
      if (field.Reachable(i)) cells.push_back(i);
    }
  }
  return cells;
}

Choice ChooseCandidate(const DistanceField& field, const CandidateConfig& config,
                       std::vector<Candidate>* candidates) {
  KESTREL_THROW_UNLESS(candidates != nullptr, "ChooseCandidate: candidates is null");
  const double d_max = DMax(config, field.MaxDistance());
  Choice choice;
  double best = -1.0;
  for (size_t c = 0; c < candidates->size(); ++c) {
    Candidate& cand = (*candidates)[c];
    cand.distance_m = field.distance_m[static_cast<size_t>(cand.cell)];
    cand.bump = Bump(cand.distance_m, d_max);
    if (c == 0 || cand.gain_nats > choice.best_unweighted_gain_nats) {
      choice.best_unweighted_gain_nats = cand.gain_nats;
    }
    if (cand.objective() > best) {  // eq. (9) with eq. (17)
      best = cand.objective();
      choice.index = static_cast<int>(c);
    }
  }
  // The end test ignores the bump: it would end exploration while distant gain remains.
  choice.exploration_done =
      candidates->empty() || choice.best_unweighted_gain_nats < config.end_gain_nats;
  return choice;
}

}  // namespace kestrel

#include "exploration/candidates.h"

#include <algorithm>
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
  KESTREL_THROW_UNLESS(switch_margin >= 0.0 && std::isfinite(switch_margin),
                       "switch_margin = " << switch_margin << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(
      end_entropy_gain_nats >= 0.0 && std::isfinite(end_entropy_gain_nats),
      "end_entropy_gain_nats = " << end_entropy_gain_nats << ", accepted [0, inf)");
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
  // One candidate per lattice block: the lattice cell itself when reachable, else the block's
  // reachable cell nearest to it (ties: lowest index), so a corridor one collision cell wide
  // between lattice rows or columns still has candidates.
  const int step = config.lattice_step;
  std::vector<int> cells;
  for (int y0 = 0; y0 < field.height; y0 += step) {
    for (int x0 = 0; x0 < field.width; x0 += step) {
      int best = -1;
      int best_d2 = 0;
      for (int y = y0; y < std::min(y0 + step, field.height); ++y) {
        for (int x = x0; x < std::min(x0 + step, field.width); ++x) {
          const int i = x + field.width * y;
          if (config.exclude_vehicle_cell && i == field.start) continue;
          if (!field.Reachable(i)) continue;
          const int d2 = (x - x0) * (x - x0) + (y - y0) * (y - y0);
          if (best < 0 || d2 < best_d2 || (d2 == best_d2 && i < best)) {
            best = i;
            best_d2 = d2;
          }
        }
      }
      if (best >= 0) cells.push_back(best);
    }
  }
  std::sort(cells.begin(), cells.end());
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

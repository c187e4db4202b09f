#include "tools/fidelity/fidelity.h"

#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>

#include "common/config.h"
#include "sim/ray_reach.h"
#include "tools/fidelity/log_replay.h"
#include "tools/fidelity/octomap_peer.h"
#include "tools/map_score/map_scorer.h"

namespace kestrel {

double EntropyBits(const std::vector<double>& probability, const std::vector<uint8_t>& mask) {
  double h = 0.0;
  for (size_t i = 0; i < probability.size(); ++i) {
    if (mask[i] == 0) continue;
    const double p = probability[i];
    if (p > 0.0 && p < 1.0) h -= p * std::log2(p) + (1.0 - p) * std::log2(1.0 - p);
  }
  return h;
}

namespace {

bool Known(double p, double prior) { return p < 0.5 * prior || p > 0.5; }

}  // namespace

FidelityResult RunFidelity(const FidelityConfig& config) {
  const World world = LoadWorld(PathUnderRoot(config.root, config.world_file));
  LogReplay replay;
  std::vector<MapperConfig> mapper_configs;
  for (const FidelityVariant& v : config.variants) {
    std::vector<std::string> overrides = config.base_overrides;
    overrides.insert(overrides.end(), v.mapper_overrides.begin(), v.mapper_overrides.end());
    mapper_configs.push_back(
        LoadReplayMapperConfig(config.root, config.mapper_file, overrides, world));
    replay.AddMapper(mapper_configs.back());
  }
  if (replay.size() == 0) throw std::runtime_error("RunFidelity: no Kestrel mapper to compare");
  const GridGeometry& geometry = replay.mapper(0).geometry();
  const GridSpec grid = GridSpecOf(geometry);
  const WorldRayCaster caster(world);
  const MapScorer scorer(world, caster, grid, config.scoring_range_m, config.scoring_vfov_rad,
                         mapper_configs.front().sensors.front().model.no_return_informs,
                         config.scoring_camera_depth_range_m);

  std::unique_ptr<OctoMapPeer> octomap;
  if (config.octomap) {
    octomap = std::make_unique<OctoMapPeer>(grid);
    // The first variant's node pairs scans with poses; OctoMap gets exactly its scans.
    replay.mapper(0).SetScanObserver([&](const MapperNode::AppliedScan& s) {
      octomap->InsertScan(s.Rays(), s.model->config().z_max_m);
    });
  }

  const size_t n = replay.size() + (octomap ? 1 : 0);
  std::vector<std::string> labels;
  std::vector<double> priors;
  for (size_t i = 0; i < replay.size(); ++i) {
    labels.push_back(config.variants[i].label);
    priors.push_back(replay.mapper(i).PriorProbability());
  }
  if (octomap) labels.push_back("octomap"), priors.push_back(0.5);
  // The probabilities of map i now.
  const auto probabilities = [&](size_t i) {
    if (i < replay.size()) {
      MapperNode& m = replay.mapper(i);
      return scorer.Probabilities([&](const CellIndex& c) { return m.ProbabilityAt(c); });
    }
    return scorer.Probabilities(
        [&](const CellIndex& c) { return octomap->ProbabilityAt(Eigen::Vector3i(c.x, c.y, c.z)); });
  };

  FidelityResult result;
  std::vector<double> entropy_start(n);
  for (size_t i = 0; i < n; ++i) {
    entropy_start[i] =
        EntropyBits(std::vector<double>(grid.size(), priors[i]), scorer.observable());
  }
  // Claims without grounds (docs/algorithms.md §12.5): one tracker per map, sampled every
  // claims_period_s of log time; the reach record's times are the simulator's, as the log's.
  std::optional<RayReach> reach;
  if (!config.reach_path.empty()) {
    reach.emplace(ReadRayReachFile(PathUnderRoot(config.root, config.reach_path)));
    if (reach->grid().dims != grid.dims ||
        (reach->grid().min_m - grid.min_m).cwiseAbs().maxCoeff() > 1e-9) {
      throw std::runtime_error("RunFidelity: the reach record " + config.reach_path +
                               " is not on the mappers' lattice");
    }
  }
  std::vector<ClaimTracker> claims(n, ClaimTracker(world, grid, scorer.truth()));
  const int64_t claims_period = static_cast<int64_t>(config.claims_period_s * 1e6);
  int64_t next_claims = -1;
  const auto sample_claims = [&](int64_t utime) {
    for (size_t i = 0; i < n; ++i) {
      claims[i].Sample(1e-6 * static_cast<double>(utime),
                       KnownFreeBelow(probabilities(i), priors[i]));
    }
  };
  int64_t first_utime = -1, next_sample = -1, last_utime = 0;
  const auto sample = [&](int64_t utime) {
    for (size_t i = 0; i < n; ++i) {
      const std::vector<double> p = probabilities(i);
      FidelitySample s;
      s.t_s = 1e-6 * static_cast<double>(utime - first_utime);
      s.label = labels[i];
      s.quality = ComputeMapQuality(p, scorer.truth(), scorer.observable(), priors[i]);
      s.entropy_bits = EntropyBits(p, scorer.observable());
      result.curve.push_back(s);
    }
  };
  const int64_t period = static_cast<int64_t>(config.sample_period_s * 1e6);
  replay.Run(PathUnderRoot(config.root, config.log_path), [&](int64_t utime) {
    if (first_utime < 0) first_utime = utime, next_sample = utime + period, next_claims = utime;
    last_utime = utime;
    if (reach && claims_period > 0 && utime >= next_claims) {
      sample_claims(utime);
      next_claims += claims_period;
    }
    if (period > 0 && utime >= next_sample) {
      sample(utime);
      next_sample += period;
    }
  });
  if (first_utime < 0)
    throw std::runtime_error("RunFidelity: the log " + config.log_path + " is empty");
  result.log_duration_s = 1e-6 * static_cast<double>(last_utime - first_utime);
  sample(last_utime);
  if (reach) sample_claims(last_utime);

  // Final figures, and the cells known in every map.
  std::vector<std::vector<double>> finals;
  for (size_t i = 0; i < n; ++i) finals.push_back(probabilities(i));
  std::vector<uint8_t> common = scorer.observable();
  for (size_t c = 0; c < common.size(); ++c) {
    for (size_t i = 0; i < n && common[c] != 0; ++i) {
      if (!Known(finals[i][c], priors[i])) common[c] = 0;
    }
    result.common_known_cells += common[c];
  }
  for (size_t i = 0; i < n; ++i) {
    FidelityScore s;
    s.label = labels[i];
    s.prior = priors[i];
    s.quality = ComputeMapQuality(finals[i], scorer.truth(), scorer.observable(), priors[i]);
    const MapQuality common_quality =
        ComputeMapQuality(finals[i], scorer.truth(), common, priors[i]);
    s.common_accuracy = common_quality.accuracy;
    s.common_brier = common_quality.brier;
    const std::vector<uint8_t>& truth = scorer.truth();
    const std::vector<uint8_t>& observable = scorer.observable();
    for (int z = 0; z < grid.dims.z(); ++z) {
      for (int y = 0; y < grid.dims.y(); ++y) {
        for (int x = 0; x < grid.dims.x(); ++x) {
          const Eigen::Vector3i c(x, y, z);
          const size_t k = grid.IndexOf(c);
          if (observable[k] == 0) continue;
          const double p = finals[i][k];
          if (truth[k] != 0 && p < 0.5 * priors[i]) ++s.false_free;
          if (truth[k] != 0 || p <= 0.5) continue;
          ++s.false_occupied;
          for (int a = 0; a < 3; ++a) {
            bool at_surface = false;
            for (int step : {-1, 1}) {
              Eigen::Vector3i neighbour = c;
              neighbour[a] += step;
              if (neighbour[a] >= 0 && neighbour[a] < grid.dims[a] &&
                  truth[grid.IndexOf(neighbour)] != 0)
                at_surface = true;
            }
            if (at_surface) {
              ++s.false_occupied_at_surface;
              break;
            }
          }
        }
      }
    }
    s.claims = claims[i].Claims(KnownFreeBelow(finals[i], priors[i]),
                                reach ? &reach->first_reach_s() : nullptr);
    s.entropy_start_bits = entropy_start[i];
    s.entropy_end_bits = EntropyBits(finals[i], scorer.observable());
    s.scans = i < replay.size() ? replay.mapper(i).scans_applied() : octomap->scans();
    s.map_hash = i < replay.size() ? replay.mapper(i).map_hash() : 0;
    s.entropy_drop_per_scan_bits =
        s.scans > 0 ? (s.entropy_start_bits - s.entropy_end_bits) / static_cast<double>(s.scans)
                    : 0.0;
    result.scores.push_back(s);
  }
  return result;
}

}  // namespace kestrel

#pragma once
/// @file
/// The fidelity benchmark (docs/algorithms.md §12.3): one recorded log replayed into several
/// kestrel-mapper configurations (the exact model at different sensor models, the log-odds
/// baseline) and into OctoMap, all scored against the simulator's truth with the same
/// definitions (docs/algorithms.md §12.2), as the log goes and at its end.

#include <cstdint>
#include <string>
#include <vector>

#include "mapping/map_quality.h"
#include "sim/world.h"
#include "tools/map_score/map_claims.h"

namespace kestrel {

/// A mapper configuration to compare: the base file with these key=value overrides.
struct FidelityVariant {
  std::string label;
  std::vector<std::string> mapper_overrides;
};

struct FidelityConfig {
  std::string root{"."};   ///< relative files from here
  std::string log_path;    ///< the recorded run
  std::string world_file;  ///< its world (truth)
  std::string mapper_file{"config/mapper.yaml"};
  std::vector<std::string> base_overrides;       ///< applied to every variant first
  std::vector<FidelityVariant> variants;         ///< Kestrel mappers
  bool octomap{true};                            ///< also OctoMap (label "octomap")
  double sample_period_s{10.0};                  ///< curve samples every this much log time, s
  double scoring_range_m{4.0};                   ///< observable cells: sensor range, m
  double scoring_vfov_rad{45.0 * M_PI / 180.0};  ///< and vertical field of view
  double scoring_camera_depth_range_m{8.0};      ///< and the camera's reported depth (SensorSweep)
  /// The flight's ray reach record (kestrel-mission --reach; sim/ray_reach.h): with it, every
  /// map's claims include the cells no ray reached and the cells freed before a ray reached them
  /// ("": without those two figures).
  std::string reach_path;
  double claims_period_s{1.0};  ///< known-free samples for the freed-early figure, log s
};

/// One map's figures. The four of docs/algorithms.md §12.2 use each map's own rule and prior (an
/// untouched cell is P_init for the exact model, 0.5 for log-odds and OctoMap; known: P < prior/2
/// or P > 0.5); the "common" ones are over the cells known in every map compared, so that no map
/// gains or loses by what it leaves unknown.
struct FidelityScore {
  std::string label;
  MapQuality quality;
  double prior{0.0};               ///< P of an untouched cell
  double common_accuracy{0.0};     ///< accuracy over the common known cells
  double common_brier{0.0};        ///< Brier score over them
  double entropy_start_bits{0.0};  ///< entropy of the observable cells before the first scan
  double entropy_end_bits{0.0};    ///< and after the last
  int64_t scans{0};                ///< scans applied
  uint64_t map_hash{0};            ///< MapperNode::map_hash (0 for OctoMap)
  /// Where the known cells are wrong (observable cells): truth occupied but known free, truth
  /// free but known occupied, and of those the ones with a truth-occupied face neighbour (a
  /// surface drawn a cell too thick), the rest lying farther out.
  size_t false_free{0};
  size_t false_occupied{0};
  size_t false_occupied_at_surface{0};
  /// (entropy_start - entropy_end) / scans: the mean information a scan added, bits.
  double entropy_drop_per_scan_bits{0.0};
  /// Cells known free without grounds (docs/algorithms.md §12.5), by the map's own rule.
  MapClaims claims;
};

/// A sample of the curves.
struct FidelitySample {
  double t_s{0.0};  ///< log time since the first event, s
  std::string label;
  MapQuality quality;
  double entropy_bits{0.0};
};

struct FidelityResult {
  std::vector<FidelityScore> scores;  ///< variants in order, then OctoMap
  std::vector<FidelitySample> curve;
  size_t common_known_cells{0};
  double log_duration_s{0.0};
};

/// Runs the benchmark. @throws ConfigError, std::runtime_error (unreadable log, bad world).
[[nodiscard]] FidelityResult RunFidelity(const FidelityConfig& config);

/// Entropy of the cells in `mask` (1) of a map given as probabilities, in bits
/// (docs/algorithms.md §5, in base 2).
[[nodiscard]] double EntropyBits(const std::vector<double>& probability,
                                 const std::vector<uint8_t>& mask);

}  // namespace kestrel

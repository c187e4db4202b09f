#include "mapping/mapping_config.h"

#include <initializer_list>
#include <limits>
#include <stdexcept>

namespace kestrel {
namespace {

// Runs validate(); a failure becomes a ConfigError naming the file, the node's path and the
// struct's message (which names the offending key, value and range), attached to the first of
// `keys` present in the node so that its line is reported too.
template <class F>
void ValidateAt(const ConfigNode& node, std::initializer_list<const char*> keys, F&& validate) {
  try {
    validate();
  } catch (const std::invalid_argument& e) {
    for (const char* key : keys) {
      if (node.Has(key)) node.Fail(key, e.what());
    }
    throw ConfigError(node.file() + ": '" + node.path() + "': " + e.what());
  }
}

}  // namespace

void ReadSensorModelConfig(const ConfigNode& node, SensorModelConfig* c) {
  node.Read("sigma_m", &c->sigma_m, Range::Positive());
  node.Read("z_min_m", &c->z_min_m, Range::NonNegative());
  node.Read("z_max_m", &c->z_max_m, Range::Positive());
  node.Read("p_rand", &c->p_rand, Range::Open(0.0, 1.0));
  node.Read("p_miss", &c->p_miss, Range::Open(0.0, 1.0));
  node.Read("cutoff_sigmas", &c->cutoff_sigmas, Range::AtLeast(5.0));
  node.Read("interpolated_gaussian", &c->interpolated_gaussian);
  node.Read("no_return_informs", &c->no_return_informs);
  node.Read("direction_uncertainty_rad", &c->direction_uncertainty_rad, Range::Closed(0.0, 0.2));
  node.Read("band_surface_max_m", &c->band_surface_max_m, Range::NonNegative());
  ValidateAt(node, {"z_max_m", "z_min_m", "sigma_m", "p_rand", "p_miss", "cutoff_sigmas"},
             [&] { c->Validate(); });
}

void ReadMapLimits(const ConfigNode& node, MapLimits* limits) {
  node.Read("min_m", &limits->min_m);
  node.Read("max_m", &limits->max_m);
  node.Read("resolution_m", &limits->resolution_m, Range::Positive());
  ValidateAt(node, {"max_m", "min_m", "resolution_m"}, [&] { limits->Validate(); });
}

void ReadOccupancyLimits(const ConfigNode& node, OccupancyLimits* limits) {
  node.Read("p_init", &limits->p_init, Range::Open(0.0, 1.0));
  node.Read("p_min", &limits->p_min, Range::Open(0.0, 0.5));
  ValidateAt(node, {"p_init", "p_min"}, [&] { limits->Validate(); });
}

void ReadLogOddsConfig(const ConfigNode& node, LogOddsConfig* c) {
  node.Read("p_hit", &c->p_hit, Range::Open(0.5, 1.0));
  node.Read("p_miss", &c->p_miss, Range::Open(0.0, 0.5));
  node.Read("p_clamp_min", &c->p_clamp_min, Range::Open(0.0, 1.0));
  node.Read("p_clamp_max", &c->p_clamp_max, Range::Open(0.0, 1.0));
  node.Read("p_unknown", &c->p_unknown, Range::Open(0.0, 1.0));
  ValidateAt(node, {"p_clamp_min", "p_clamp_max", "p_unknown", "p_hit", "p_miss"},
             [&] { c->Validate(); });
}

void ReadPoseHistoryConfig(const ConfigNode& node, PoseHistoryConfig* c) {
  node.Read("history_s", &c->history_s, Range::Positive());
  node.Read("max_gap_s", &c->max_gap_s, Range::Positive());
  node.Read("max_wait_s", &c->max_wait_s, Range::Positive());
  ValidateAt(node, {"max_gap_s", "history_s", "max_wait_s"}, [&] { c->Validate(); });
}

}  // namespace kestrel

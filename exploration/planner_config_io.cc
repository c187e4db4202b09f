#include "exploration/planner_config_io.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/config.h"

namespace kestrel {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

void ReadSensor(const ConfigNode& n, GainSensor* s, VolumetricSensor* v) {
  std::string name;
  n.Read("name", &name);  // a label for humans
  v->name = name;
  // The volumetric mode's 3D rays (docs/exploration.md, "Volumetric gain"): 0 = a planar scanner.
  double vfov_deg = v->vertical_fov_rad / kDegToRad;
  n.Read("vertical_fov_deg", &vfov_deg, Range{0.0, 180.0, true, false});
  v->vertical_fov_rad = vfov_deg * kDegToRad;
  s->planar = vfov_deg == 0.0;
  n.Read("rows", &v->rows, Range::Closed(1, 1000));
  n.Read("height_offset_m", &v->height_offset_m);
  s->height_offset_m = v->height_offset_m;
  double fov_deg = s->horizontal_fov_rad / kDegToRad;
  double yaw_deg = s->yaw_offset_rad / kDegToRad;
  n.Read("horizontal_fov_deg", &fov_deg, Range{0.0, 360.0, false, true});
  n.Read("yaw_offset_deg", &yaw_deg, Range::Closed(-360.0, 360.0));
  s->horizontal_fov_rad = fov_deg * kDegToRad;
  s->yaw_offset_rad = yaw_deg * kDegToRad;
  n.Read("sigma_m", &s->model.sigma_m, Range::Positive());
  n.Read("z_min_m", &s->model.z_min_m, Range::NonNegative());
  n.Read("z_max_m", &s->model.z_max_m, Range::Positive());
  n.Read("p_rand", &s->model.p_rand, Range::Open(0.0, 1.0));
  n.Read("p_miss", &s->model.p_miss, Range::Open(0.0, 1.0));
  n.Read("cutoff_sigmas", &s->model.cutoff_sigmas, Range::AtLeast(5.0));
  n.Read("interpolated_gaussian", &s->model.interpolated_gaussian);
  n.Read("no_return_informs", &s->model.no_return_informs);
  // Range bands (docs/algorithms.md §3.8): the volumetric gain predicts the mapper's bands.
  n.Read("direction_uncertainty_rad", &s->model.direction_uncertainty_rad, Range::Closed(0.0, 0.2));
  n.Read("band_surface_max_m", &s->model.band_surface_max_m, Range::NonNegative());
  n.Read("reports_to_m", &v->reports_to_m, Range::NonNegative());
  v->model = s->model;
  v->horizontal_fov_rad = s->horizontal_fov_rad;
  v->yaw_offset_rad = s->yaw_offset_rad;
}

}  // namespace

PlannerConfig LoadPlannerConfig(const ConfigNode& node) {
  PlannerConfig c;
  std::string mode = ModeName(c.mode);
  node.Read(
      "mode", &mode,
      std::vector<std::string>{"combined", "two_map", "frontier", "volumetric", "volumetric_tour"});
  c.mode = mode == "two_map"           ? ExplorationMode::kTwoMap
           : mode == "frontier"        ? ExplorationMode::kFrontier
           : mode == "volumetric"      ? ExplorationMode::kVolumetric
           : mode == "volumetric_tour" ? ExplorationMode::kVolumetricTour
                                       : ExplorationMode::kCombined;
  double vfov_deg = c.startup_vertical_fov_rad / kDegToRad;
  node.Read("startup_vertical_fov_deg", &vfov_deg, Range::Open(0.0, 180.0));
  c.startup_vertical_fov_rad = vfov_deg * kDegToRad;

  if (node.Has("projection")) {
    const ConfigNode p = node.Child("projection");
    ProjectionConfig& q = c.projection;
    p.Read("height_m", &q.height_m);
    p.Read("collision_factor", &q.collision_factor, Range::Closed(0, 1000));
    p.Read("vehicle_diameter_m", &q.vehicle_diameter_m, Range::Positive());
    p.Read("collision_threshold", &q.collision_threshold, Range{0.0, 1.0, true, false});
    p.Read("floor_height_m", &q.floor_height_m);
    p.Read("ceiling_height_m", &q.ceiling_height_m);
    p.Read("p_min_entropy", &q.p_min_entropy, Range::Open(0.0, 0.5));
    // One value for the map's clamp: the volumetric gain reads a cell at it as certain, as E's
    // floor (eq. 15) does (docs/exploration.md, "Volumetric gain").
    c.volumetric.gain.certain_probability = q.p_min_entropy;
    p.Read("p_thresh", &q.p_thresh, Range::Open(0.0, 1.0));
    p.Read("p_init", &q.p_init, Range::Open(0.0, 1.0));
  }
  if (node.Has("gain")) {
    const ConfigNode g = node.Child("gain");
    g.Read("rays_per_revolution", &c.gain.rays_per_revolution, Range::Closed(4, 36000));
    std::string weight = "chord_probability";
    g.Read("weight_mode", &weight, std::vector<std::string>{"chord_probability", "paper_literal"});
    c.gain.weight_mode =
        weight == "paper_literal" ? WeightMode::kPaperLiteral : WeightMode::kChordProbability;
    std::string method = "fast";
    g.Read("method", &method, std::vector<std::string>{"fast", "direct"});
    c.gain.method = method == "direct" ? GainMethod::kDirect : GainMethod::kFast;
    const std::vector<ConfigNode> sensors = g.Elements("sensors", false);
    if (!sensors.empty()) {
      c.gain.sensors.clear();
      c.volumetric.gain.sensors.clear();
      for (const ConfigNode& s : sensors) {
        GainSensor sensor;
        VolumetricSensor rays;
        ReadSensor(s, &sensor, &rays);
        c.gain.sensors.push_back(sensor);
        c.volumetric.gain.sensors.push_back(rays);
      }
    }
  }
  if (node.Has("candidates")) {
    const ConfigNode n = node.Child("candidates");
    CandidateConfig& q = c.candidates;
    n.Read("lattice_step", &q.lattice_step, Range::Closed(1, 1000));
    n.Read("n_yaw", &q.n_yaw, Range::Closed(1, 360));
    std::string policy = q.d_max_policy == DMaxPolicy::kSimulation ? "simulation" : "experiment";
    n.Read("d_max_policy", &policy, std::vector<std::string>{"simulation", "experiment"});
    q.d_max_policy = policy == "simulation" ? DMaxPolicy::kSimulation : DMaxPolicy::kExperiment;
    n.Read("d_max_epsilon", &q.d_max_epsilon, Range::NonNegative());
    n.Read("d_fixed_m", &q.d_fixed_m, Range::Positive());
    n.Read("end_gain_nats", &q.end_gain_nats, Range::NonNegative());
    n.Read("end_entropy_gain_nats", &q.end_entropy_gain_nats, Range::NonNegative());
    n.Read("end_check_entropy_map", &q.end_check_entropy_map);
    n.Read("exclude_vehicle_cell", &q.exclude_vehicle_cell);
    n.Read("skip_reached_goals", &q.skip_reached_goals);
    n.Read("switch_margin", &q.switch_margin, Range::NonNegative());
  }
  bool radius_set = false;
  if (node.Has("trajectory")) {
    const ConfigNode t = node.Child("trajectory");
    TrajectoryConfig& q = c.trajectory;
    t.Read("max_speed_mps", &q.max_speed_mps, Range::Positive());
    t.Read("max_acceleration_mps2", &q.max_acceleration_mps2, Range::Positive());
    t.Read("max_yaw_rate_radps", &q.max_yaw_rate_radps, Range::Positive());
    t.Read("derivative_order", &q.derivative_order, Range::Closed(3, 4));
    t.Read("sample_period_s", &q.sample_period_s, Range{0.0, 1.0, false, true});
    radius_set = t.Has("vehicle_radius_m");
    t.Read("vehicle_radius_m", &q.vehicle_radius_m, Range::Positive());
    t.Read("min_segment_duration_s", &q.min_segment_duration_s, Range::Positive());
    t.Read("max_repair_rounds", &q.max_repair_rounds, Range::Closed(0, 50));
  }
  if (!radius_set) c.trajectory.vehicle_radius_m = 0.5 * c.projection.vehicle_diameter_m;
  if (node.Has("frontier")) {
    ReadParams(node.Child("frontier"), FrontierParams(), &c.frontier);
  }
  if (node.Has("volumetric")) {
    const ConfigNode v = node.Child("volumetric");
    ReadParams(v, VolumetricParams(), &c.volumetric);
    v.Read("azimuth_bins", &c.volumetric.gain.azimuth_bins, Range::Closed(4, 36000));
  }
  node.CheckNoUnknownKeys();
  try {
    c.Validate();  // cross-field checks (p_thresh > p_init, z_max > z_min, ...)
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return c;
}

PlannerConfig LoadPlannerConfigFile(const std::string& path) {
  return LoadPlannerConfig(ConfigNode::LoadFile(path));
}

}  // namespace kestrel

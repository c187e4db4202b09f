#include "exploration/planner_config_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/config.h"
#include "exploration/explorer_config.h"
#include "tests/exploration/param_table_checks.h"

namespace kestrel {
namespace {

// The reference file loads and equals the built-in defaults (it documents them). The explorer's
// own keys: tests/exploration/explorer_config_test.cc.
TEST(PlannerConfigIo, ReferenceFileEqualsDefaults) {
  // The file also holds the explorer node's section, so it loads as the explorer loads it.
  const PlannerConfig c =
      LoadExplorerNodeConfig(ConfigNode::LoadFile(KESTREL_CONFIG_DIR "/exploration/explorer.yaml"))
          .explorer.planner;
  const PlannerConfig d;
  EXPECT_EQ(c.mode, d.mode);
  EXPECT_EQ(c.projection.height_m, d.projection.height_m);
  EXPECT_EQ(c.projection.collision_factor, d.projection.collision_factor);
  EXPECT_EQ(c.projection.p_thresh, d.projection.p_thresh);
  EXPECT_TRUE(std::isinf(c.projection.ceiling_height_m));
  ASSERT_EQ(c.gain.sensors.size(), d.gain.sensors.size());
  for (size_t i = 0; i < d.gain.sensors.size(); ++i) {
    EXPECT_NEAR(c.gain.sensors[i].horizontal_fov_rad, d.gain.sensors[i].horizontal_fov_rad, 1e-12);
    EXPECT_EQ(c.gain.sensors[i].model.sigma_m, d.gain.sensors[i].model.sigma_m);
  }
  EXPECT_EQ(c.candidates.n_yaw, d.candidates.n_yaw);
  EXPECT_EQ(c.candidates.d_max_policy, d.candidates.d_max_policy);
  EXPECT_EQ(c.candidates.skip_reached_goals, d.candidates.skip_reached_goals);
  EXPECT_EQ(c.candidates.switch_margin, d.candidates.switch_margin);
  EXPECT_EQ(c.trajectory.vehicle_radius_m, d.trajectory.vehicle_radius_m);
  EXPECT_NEAR(c.startup_vertical_fov_rad, d.startup_vertical_fov_rad, 1e-12);
  EXPECT_EQ(c.projection.p_min_entropy, d.projection.p_min_entropy);
  EXPECT_EQ(c.trajectory.max_speed_mps, d.trajectory.max_speed_mps);
  EXPECT_EQ(c.trajectory.max_acceleration_mps2, d.trajectory.max_acceleration_mps2);
  EXPECT_EQ(c.trajectory.max_yaw_rate_radps, d.trajectory.max_yaw_rate_radps);
  EXPECT_EQ(c.frontier.fine_traversability, d.frontier.fine_traversability);
  EXPECT_EQ(c.volumetric.band_below_m, d.volumetric.band_below_m);
  EXPECT_EQ(c.volumetric.band_above_m, d.volumetric.band_above_m);
  EXPECT_EQ(c.volumetric.margin_m, d.volumetric.margin_m);
  EXPECT_EQ(c.volumetric.passage_margin_m, d.volumetric.passage_margin_m);
  EXPECT_EQ(c.volumetric.candidate_spacing_m, d.volumetric.candidate_spacing_m);
  EXPECT_EQ(c.volumetric.end_gain_nats, d.volumetric.end_gain_nats);
  EXPECT_EQ(c.volumetric.gain.azimuth_bins, d.volumetric.gain.azimuth_bins);
  ASSERT_EQ(c.volumetric.gain.sensors.size(), d.volumetric.gain.sensors.size());
  for (size_t i = 0; i < d.volumetric.gain.sensors.size(); ++i) {
    const VolumetricSensor& a = c.volumetric.gain.sensors[i];
    const VolumetricSensor& b = d.volumetric.gain.sensors[i];
    EXPECT_NEAR(a.vertical_fov_rad, b.vertical_fov_rad, 1e-12) << b.name;
    EXPECT_EQ(a.rows, b.rows) << b.name;
    EXPECT_EQ(a.height_offset_m, b.height_offset_m) << b.name;
    EXPECT_NEAR(a.horizontal_fov_rad, b.horizontal_fov_rad, 1e-12) << b.name;
    EXPECT_EQ(a.model.sigma_m, b.model.sigma_m) << b.name;
  }
}

// Bad values and unknown keys name the file and key.
TEST(PlannerConfigIo, ErrorsNameKey) {
  const auto message = [](const std::string& yaml) {
    try {
      (void)LoadPlannerConfig(ConfigNode::FromString(yaml, "test.yaml"));
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("mode: sideways\n").find("mode"), std::string::npos);
  EXPECT_NE(message("candidates:\n  n_yaw: 0\n").find("n_yaw"), std::string::npos);
  EXPECT_NE(message("projection:\n  p_thresh: 0.05\n").find("p_thresh"), std::string::npos);
  EXPECT_NE(message("projection:\n  hieght_m: 1\n").find("hieght_m"), std::string::npos);
  EXPECT_NE(message("gain:\n  sensors:\n    - z_min_m: 5\n").find("z_max_m"), std::string::npos);
  // Two-map mode, minimum jerk, radius from the diameter.
  const PlannerConfig c = LoadPlannerConfig(ConfigNode::FromString(
      "mode: two_map\nprojection:\n  vehicle_diameter_m: 0.5\ntrajectory:\n  derivative_order: 3\n",
      "test.yaml"));
  EXPECT_EQ(c.mode, ExplorationMode::kTwoMap);
  EXPECT_EQ(c.trajectory.derivative_order, 3);
  EXPECT_EQ(c.trajectory.vehicle_radius_m, 0.25);
}

// The frontier and volumetric sections: every key of their tables at its default in the
// reference file, and one range per key for the loader and the validation.
TEST(PlannerConfigIo, FrontierAndVolumetricKeysFromOneTable) {
  const PlannerConfig c =
      LoadExplorerNodeConfig(ConfigNode::LoadFile(KESTREL_CONFIG_DIR "/exploration/explorer.yaml"))
          .explorer.planner;
  const PlannerConfig d;
  for (const Param<FrontierConfig>& p : FrontierParams()) {
    EXPECT_EQ(test::ParamValue(c.frontier, p), test::ParamValue(d.frontier, p)) << p.key;
  }
  for (const Param<VolumetricConfig>& p : VolumetricParams()) {
    EXPECT_EQ(test::ParamValue(c.volumetric, p), test::ParamValue(d.volumetric, p)) << p.key;
  }
  const auto load = [](const std::string& yaml) {
    return LoadPlannerConfig(ConfigNode::FromString(yaml, "test.yaml"));
  };
  test::ExpectRangesEnforced("volumetric", VolumetricParams(), VolumetricConfig{}, load,
                             [](const VolumetricConfig& v) { v.Validate(); });
  test::ExpectRangesEnforced("frontier", FrontierParams(), FrontierConfig{}, load,
                             [](const FrontierConfig& f) {
                               PlannerConfig with = PlannerConfig{};
                               with.frontier = f;
                               with.Validate();
                             });
  // Finite: an infinite band is refused by both.
  EXPECT_THROW(load("volumetric: {band_below_m: .inf}"), ConfigError);
}

TEST(PlannerConfigIo, TheMapsClampIsOneValueForEAndTheVolumetricGain) {
  EXPECT_EQ(LoadPlannerConfig(ConfigNode::FromString("mode: volumetric\n", "test.yaml"))
                .volumetric.gain.certain_probability,
            1e-4);
  const PlannerConfig c = LoadPlannerConfig(
      ConfigNode::FromString("projection:\n  p_min_entropy: 0.03\n", "test.yaml"));
  EXPECT_EQ(c.projection.p_min_entropy, 0.03);
  EXPECT_EQ(c.volumetric.gain.certain_probability, 0.03);
}

}  // namespace
}  // namespace kestrel

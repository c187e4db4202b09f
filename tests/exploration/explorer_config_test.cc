// The explorer's configuration: one table of keys and ranges for the loader and the validation,
// a reference file that states the defaults and describes every key, and the values the
// explorer shares with the mapper and the vehicle (sensor models, prior, clamp, diameter, sensor
// heights), which must agree between their files.
#include "exploration/explorer_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <string>

#include "common/config.h"
#include "common/vehicle_config.h"
#include "mapping/mapper_config.h"
#include "tests/exploration/param_table_checks.h"

namespace kestrel {
namespace {

const std::string kExplorerYaml = KESTREL_CONFIG_DIR "/exploration/explorer.yaml";

// The line of `key` in the `explorer:` section of the reference file ("" if absent).
std::string ExplorerLine(const std::string& key) {
  std::ifstream in(kExplorerYaml);
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != ' ' && line[0] != '#') inside = line.rfind("explorer:", 0) == 0;
    if (inside && std::regex_search(line, std::regex("^  " + key + ":"))) return line;
  }
  return "";
}

// Every key of the table is in the reference file, with a comment, at the struct's default.
template <class T>
void ExpectDocumentedAtDefault(const ParamTable<T>& table, const T& loaded, const T& defaults) {
  for (const Param<T>& p : table) {
    SCOPED_TRACE(p.key);
    const std::string line = ExplorerLine(p.key);
    ASSERT_FALSE(line.empty()) << "not in " << kExplorerYaml;
    EXPECT_NE(line.find('#'), std::string::npos) << "no comment: " << line;
    EXPECT_EQ(test::ParamValue(loaded, p), test::ParamValue(defaults, p))
        << "the file and the struct disagree";
  }
}

TEST(ExplorerConfig, ReferenceFileStatesTheDefaultsOfEveryKey) {
  const ExplorerNodeConfig n = LoadExplorerNodeConfig(ConfigNode::LoadFile(kExplorerYaml));
  const ExplorerNodeConfig d;
  ExpectDocumentedAtDefault(ExplorerParams(), n.explorer, d.explorer);
  ExpectDocumentedAtDefault(ExplorerNodeParams(), n, d);
  EXPECT_EQ(n.explorer.startup_yaw_profile, d.explorer.startup_yaw_profile);
  EXPECT_EQ(n.explorer.peers, d.explorer.peers);
  EXPECT_EQ(n.map_channel, d.map_channel);
  EXPECT_EQ(n.pose_channel, d.pose_channel);
  EXPECT_EQ(n.heartbeat_channel, d.heartbeat_channel);
}

// The loader and the validation refuse the same values: each number just outside its row's
// range is a ConfigError from the file and an invalid_argument from Validate, both naming the key.
TEST(ExplorerConfig, LoaderAndValidationShareOneRangePerKey) {
  const auto load = [](const std::string& yaml) {
    return LoadExplorerNodeConfig(ConfigNode::FromString(yaml, "test.yaml"));
  };
  const auto validate = [](const auto& config) { config.Validate(); };
  test::ExpectRangesEnforced("explorer", ExplorerParams(), ExplorerConfig{}, load, validate);
  test::ExpectRangesEnforced("explorer", ExplorerNodeParams(), ExplorerNodeConfig{}, load,
                             validate);
  // Strict ends are strict: end_stall_min_growth in [0, 1).
  EXPECT_THROW(load("explorer: {end_stall_min_growth: 1.0}"), ConfigError);
  EXPECT_NO_THROW(load("explorer: {end_stall_min_growth: 0.0}"));
}

// The values the explorer keeps in step with the mapper and the vehicle: its sensors' models
// (by name) are the mapper's, its P_init and P_min_E the mapper's prior and clamp, its vehicle
// diameter and sensor heights the vehicle file's. (kestrel-mission also sets the explorer's
// lattice, P_init, height and diameter from the mapper, the world and the vehicle; the process
// sheets pass the files as they are.)
TEST(ExplorerConfig, SharedValuesAgreeWithTheMapperAndTheVehicle) {
  const ExplorerConfig e = LoadExplorerNodeConfig(ConfigNode::LoadFile(kExplorerYaml)).explorer;
  const MapperConfig m = LoadMapperConfig(ConfigNode::LoadFile(KESTREL_CONFIG_DIR "/mapper.yaml"));
  const VehicleConfig v = LoadVehicleConfigFile(KESTREL_CONFIG_DIR "/vehicle/paper.yaml");
  EXPECT_EQ(e.planner.projection.p_init, m.occupancy.p_init);
  EXPECT_EQ(e.p_init, m.occupancy.p_init);
  EXPECT_EQ(e.planner.projection.p_min_entropy, m.occupancy.p_min);
  EXPECT_EQ(e.planner.volumetric.gain.certain_probability, m.occupancy.p_min);
  EXPECT_EQ(e.planner.projection.vehicle_diameter_m, v.diameter_m);
  EXPECT_EQ(e.planner.trajectory.vehicle_radius_m, 0.5 * v.diameter_m);
  ASSERT_EQ(e.planner.gain.sensors.size(), m.sensors.size());
  for (size_t i = 0; i < m.sensors.size(); ++i) {
    const MapperSensorConfig& ms = m.sensors[i];
    SCOPED_TRACE(ms.name);
    const VolumetricSensor& rays = e.planner.volumetric.gain.sensors[i];
    ASSERT_EQ(rays.name, ms.name) << "the sensors in the same order";
    for (const SensorModelConfig* model : {&e.planner.gain.sensors[i].model, &rays.model}) {
      EXPECT_EQ(model->sigma_m, ms.model.sigma_m);
      EXPECT_EQ(model->z_min_m, ms.model.z_min_m);
      EXPECT_EQ(model->z_max_m, ms.model.z_max_m);
      EXPECT_EQ(model->p_rand, ms.model.p_rand);
      EXPECT_EQ(model->p_miss, ms.model.p_miss);
      EXPECT_EQ(model->cutoff_sigmas, ms.model.cutoff_sigmas);
      EXPECT_EQ(model->interpolated_gaussian, ms.model.interpolated_gaussian);
    }
    const Pose3& X_BS = ms.name == "xtion" ? v.X_BS_xtion : v.X_BS_hokuyo;
    EXPECT_NEAR(rays.height_offset_m, X_BS.p.z(), 1e-12) << "the sensor's height on the body";
  }
}

}  // namespace
}  // namespace kestrel

#include "mapping/mapping_config.h"

#include <gtest/gtest.h>

#include <string>

namespace kestrel {
namespace {

// Keys override the defaults they name; absent keys keep them.
TEST(MappingConfig, ReadsSensorModelOnTopOfDefaults) {
  const ConfigNode root = ConfigNode::FromString(
      "hokuyo:\n  sigma_m: 0.08\n  z_max_m: 5.0\n  interpolated_gaussian: false\n", "test.yaml");
  SensorModelConfig c = SensorModelConfig::Hokuyo();
  ReadSensorModelConfig(root.Child("hokuyo"), &c);
  EXPECT_EQ(c.sigma_m, 0.08);
  EXPECT_EQ(c.z_max_m, 5.0);
  EXPECT_EQ(c.z_min_m, 0.5);
  EXPECT_FALSE(c.interpolated_gaussian);
  root.CheckNoUnknownKeys();
}

// A bad value names the file and the key; a cross-field failure (z_max below z_min) is reported
// at the sensor's node.
TEST(MappingConfig, ErrorsNameFileAndKey) {
  const auto error_of = [](const std::string& yaml) {
    try {
      SensorModelConfig c;
      ReadSensorModelConfig(ConfigNode::FromString(yaml, "sensors.yaml").Child("xtion"), &c);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string bad_sigma = error_of("xtion:\n  sigma_m: -1\n");
  EXPECT_NE(bad_sigma.find("sensors.yaml"), std::string::npos) << bad_sigma;
  EXPECT_NE(bad_sigma.find("sigma_m"), std::string::npos) << bad_sigma;
  const std::string crossed = error_of("xtion:\n  z_min_m: 3.0\n  z_max_m: 2.0\n");
  EXPECT_NE(crossed.find("z_max_m"), std::string::npos) << crossed;
  MapLimits limits;
  EXPECT_THROW(
      ReadMapLimits(ConfigNode::FromString("min_m: [0, 0, 0]\nmax_m: [0, 1, 1]\n", "m"), &limits),
      ConfigError);
  PoseHistoryConfig ph;
  ReadPoseHistoryConfig(ConfigNode::FromString("max_gap_s: 0.05\n", "p"), &ph);
  EXPECT_EQ(ph.max_gap_s, 0.05);
}

}  // namespace
}  // namespace kestrel

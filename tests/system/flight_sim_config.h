#pragma once
/// @file
/// The simulator configuration of the flight tests: config/sim/sim_ci.yaml in lasr, without the
/// depth camera and the LIDAR (the controller needs motion capture and the IMU only).

#include <string>

#include "common/config.h"

namespace kestrel::testing {

/// sim_ci.yaml with lasr's world and no range sensors; further overrides may follow.
inline ConfigNode FlightSimConfig() {
  ConfigNode sim_cfg =
      ConfigNode::LoadFile(std::string(KESTREL_SOURCE_DIR) + "/config/sim/sim_ci.yaml");
  sim_cfg.ApplyOverride("world_file=" + std::string(KESTREL_SOURCE_DIR) +
                        "/config/worlds/lasr.yaml");
  sim_cfg.ApplyOverride("depth.enabled=false");
  sim_cfg.ApplyOverride("lidar.enabled=false");
  return sim_cfg;
}

}  // namespace kestrel::testing

#pragma once
/// @file
/// Replays a recorded LCM log into kestrel-mapper nodes in one process (MapperNode's
/// HandleRecorded: the map a live mapper that kept up would make, bit for bit), for the fidelity
/// benchmark and the sensor calibration (tools/fidelity). The map limits are the world's, as in
/// kestrel-mission and scripts/world-env.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "mapping/mapper_node.h"
#include "sim/world.h"

namespace kestrel {

/// The mapper configuration file (relative: to `root`) with key=value overrides applied, the
/// world's map limits, no checkpoint and no catch-up log. @throws ConfigError on a bad file,
/// override or unknown key.
[[nodiscard]] MapperConfig LoadReplayMapperConfig(const std::string& root,
                                                  const std::string& mapper_file,
                                                  const std::vector<std::string>& overrides,
                                                  const World& world);

/// Mapper nodes fed from one log. Each node publishes nothing (nothing calls its PublishDue).
class LogReplay {
 public:
  LogReplay();
  /// Adds a node with `config`; returns its index. Add all before Run.
  size_t AddMapper(const MapperConfig& config);
  [[nodiscard]] MapperNode& mapper(size_t i) { return *mappers_.at(i); }
  [[nodiscard]] size_t size() const { return mappers_.size(); }

  /// Feeds every event of the log at `path` to every node, in log order, then applies what is
  /// left queued. `every` (if set) is called before each event with its log time (us), to sample
  /// the maps as the log goes. @throws std::runtime_error if the log cannot be read.
  void Run(const std::string& path, const std::function<void(int64_t)>& every = nullptr);

 private:
  lcm::LCM lcm_;
  SimClock clock_;
  std::vector<std::unique_ptr<MapperNode>> mappers_;
};

}  // namespace kestrel

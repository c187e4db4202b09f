#include "tools/fidelity/log_replay.h"

#include <stdexcept>

#include "common/config.h"

namespace kestrel {

MapperConfig LoadReplayMapperConfig(const std::string& root, const std::string& mapper_file,
                                    const std::vector<std::string>& overrides, const World& world) {
  ConfigNode node = ConfigNode::LoadFile(PathUnderRoot(root, mapper_file));
  for (const auto& o : overrides) node.ApplyOverride(o);
  MapperConfig config = LoadMapperConfig(node);
  node.CheckNoUnknownKeys();
  config.limits.min_m = world.map_min_m;
  config.limits.max_m = world.map_max_m;
  config.checkpoint_path.clear();
  config.catch_up_log.clear();
  config.traversal_thread = false;
  return config;
}

LogReplay::LogReplay() : lcm_("memq://") {
  if (!lcm_.good()) throw std::runtime_error("LogReplay: cannot open memq:// LCM");
}

size_t LogReplay::AddMapper(const MapperConfig& config) {
  mappers_.push_back(std::make_unique<MapperNode>(lcm_, config, clock_));
  return mappers_.size() - 1;
}

void LogReplay::Run(const std::string& path, const std::function<void(int64_t)>& every) {
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error("cannot read the log " + path);
  for (const lcm::LogEvent* e = log.readNextEvent(); e != nullptr; e = log.readNextEvent()) {
    if (e->timestamp > clock_.NowUtime()) clock_.SetUtime(e->timestamp);
    if (every) every(e->timestamp);
    for (auto& m : mappers_) m->HandleRecorded(e->channel, e->data, e->datalen);
  }
  for (auto& m : mappers_) m->ApplyRemaining();
}

}  // namespace kestrel

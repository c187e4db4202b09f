#include "viewer/foxglove/foxglove_node.h"

#include <vector>

#include "common/log.h"

namespace kestrel::foxglove {
namespace {
const char* const kMapTopic = "/map";
}  // namespace

FoxgloveNode::FoxgloveNode(lcm::LCM& lcm, const FoxgloveNodeConfig& config, const Clock& clock)
    : lcm_(lcm), config_(config), clock_(clock), bridge_(config.bridge), server_(config.server) {
  if (!(config_.map_rate_hz > 0)) throw std::invalid_argument("map_rate_hz must be above 0");
  const BridgeConfig& b = config_.bridge;
  const std::string channels = b.map_channel + "|" + b.delta_channel + "|" + b.pose_channel + "|" +
                               b.trajectory_channel + "|" + b.exploration_channel + "|" +
                               b.map2d_prefix + ".*|" + b.params_prefix + ".*";
  subscription_ = lcm_.subscribe(channels, &FoxgloveNode::Handle, this);
  // /map is advertised from the start and rendered only while someone subscribes to it (the
  // cubes' JSON is most of the endpoint's work); a new subscriber gets the whole map.
  server_.Advertise(kMapTopic, "foxglove.SceneUpdate");
  server_.SetSnapshotSource(kMapTopic, [this]() {
    const std::optional<Message> whole = bridge_.MapSnapshot();
    return whole ? FoxgloveServer::Snapshot{whole->time_ns, whole->json}
                 : FoxgloveServer::Snapshot{0, ""};
  });
  Log(LogLevel::kInfo, "Foxglove endpoint: ws://" + config_.server.host + ":" +
                           std::to_string(server_.port()) + " (" + kSubprotocol + ")");
}

FoxgloveNode::~FoxgloveNode() {
  if (subscription_ != nullptr) lcm_.unsubscribe(subscription_);
}

void FoxgloveNode::Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
  std::vector<Message> out;
  std::string error;
  if (!bridge_.OnLcm(channel, rbuf->data, rbuf->data_size, &out, &error)) {
    ++refused_;
    if (refused_by_channel_[channel]++ == 0) {
      Log(LogLevel::kWarning, "foxglove: " + channel + ": dropped a message: " + error +
                                  " (counted; said once per channel)");
    }
  }
  for (const Message& m : out) server_.Publish(m.topic, m.schema_name, m.time_ns, m.json);
}

void FoxgloveNode::PublishDue() {
  const int64_t now = clock_.NowUtime();
  if (now < next_map_utime_) return;
  next_map_utime_ = now + static_cast<int64_t>(1e6 / config_.map_rate_hz);
  const std::optional<Message> update = bridge_.TakeMapUpdate(server_.HasSubscribers(kMapTopic));
  if (!update) return;
  server_.Publish(update->topic, update->schema_name, update->time_ns, update->json);
}

}  // namespace kestrel::foxglove

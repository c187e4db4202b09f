#include "sim/standin_node.h"

#include <cmath>

#include "common/check.h"
#include "common/identity.h"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/planar_scan_t.hpp"

namespace kestrel {

void StandinConfig::Validate() const {
  KESTREL_THROW_UNLESS(sensor == "depth" || sensor == "scan",
                       "standin sensor = \"" << sensor << "\"; accepted: depth, scan");
  KESTREL_THROW_UNLESS(!device_channel.empty() && !channel.empty() && !heartbeat_channel.empty(),
                       "standin channels must not be empty");
  KESTREL_THROW_UNLESS(device_channel != channel, "standin device_channel = channel = \""
                                                      << channel
                                                      << "\"; the stand-in would hear itself");
  KESTREL_THROW_UNLESS(
      heartbeat_period_s > 0.0 && heartbeat_period_s <= 10.0,
      "standin heartbeat_period_s = " << heartbeat_period_s << "; accepted: (0, 10]");
  KESTREL_THROW_UNLESS(drop_fraction >= 0.0 && drop_fraction <= 1.0,
                       "standin drop_fraction = " << drop_fraction << "; accepted: [0, 1]");
  KESTREL_THROW_UNLESS(seed >= 0, "standin seed = " << seed << "; accepted: >= 0");
}

StandinConfig LoadStandinConfig(const ConfigNode& root) {
  StandinConfig c;
  root.Read("sensor", &c.sensor, std::vector<std::string>{"depth", "scan"});
  if (c.sensor == "scan") {
    c.device_channel = "DEV_SCAN_HOKUYO";
    c.channel = "SCAN_HOKUYO";
    c.heartbeat_channel = "HEARTBEAT_STANDIN_SCAN";
  }
  for (const char* section : {"depth", "scan"}) {
    if (!root.Has(section)) continue;
    const ConfigNode s = root.Child(section);
    if (c.sensor == section) {
      s.Read("device_channel", &c.device_channel);
      s.Read("channel", &c.channel);
      s.Read("heartbeat_channel", &c.heartbeat_channel);
    } else {  // the other sensor's section: read (so its keys are known), not used
      std::string unused;
      for (const char* key : {"device_channel", "channel", "heartbeat_channel"}) {
        s.Read(key, &unused);
      }
    }
  }
  root.Read("heartbeat_period_s", &c.heartbeat_period_s, Range{0, 10, false, true});
  root.Read("drop_fraction", &c.drop_fraction, Range::Closed(0, 1));
  root.Read("seed", &c.seed, Range::NonNegative());
  root.CheckNoUnknownKeys();
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(root.file() + ": " + e.what());
  }
  return c;
}

StandinNode::StandinNode(lcm::LCM& lcm, const StandinConfig& config, const Clock& clock)
    : lcm_(lcm),
      config_((config.Validate(), config)),
      subscriptions_(lcm),
      heartbeat_(lcm, clock, "kestrel-sim-standin", config.heartbeat_channel),
      drops_(clock),
      rng_(MixSeed(static_cast<uint64_t>(config.seed))),
      epoch_(NewPublisherEpoch()) {
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    drops_.Count("malformed", channel + ": " + reason);
    heartbeat_.SetLastError(channel + ": " + reason);
  };
  if (config_.sensor == "depth") {
    subscriptions_.Add<depth_image_t>(
        config_.device_channel,
        [this](const std::string&, const depth_image_t& msg) { Relay(msg); }, on_error);
  } else {
    subscriptions_.Add<planar_scan_t>(
        config_.device_channel,
        [this](const std::string&, const planar_scan_t& msg) { Relay(msg); }, on_error);
  }
  heartbeat_.SetState(heartbeat_t::STATE_STARTING);
}

template <typename Message>
void StandinNode::Relay(const Message& frame) {
  ++device_frames_;
  // One draw per well-formed frame: the same frames are lost for the same seed.
  if (rng_.Bernoulli(config_.drop_fraction)) {
    drops_.Count("link_loss", config_.device_channel + " frame " + std::to_string(frame.seq) +
                                  " lost on the link (drop_fraction)");
    return;
  }
  Message out = frame;
  out.seq = seq_++;
  out.epoch = epoch_;
  lcm_.publish(config_.channel, &out);
  ++relayed_;
}

void StandinNode::PublishHeartbeat() {
  heartbeat_.SetState(relayed_ > 0 ? int8_t{heartbeat_t::STATE_OK}
                                   : int8_t{heartbeat_t::STATE_STARTING});
  heartbeat_.SetValue("device_frames", static_cast<double>(device_frames_));
  heartbeat_.SetValue("relayed", static_cast<double>(relayed_));
  heartbeat_.SetValue("drop_fraction", config_.drop_fraction);
  heartbeat_.SetDropValues(drops_, {"link_loss", "malformed"});
  heartbeat_.Publish();
}

void StandinNode::AddTimers(NodeLoop& loop) {
  loop.AddTimer("standin_heartbeat", SecondsToUtime(config_.heartbeat_period_s),
                [this](int64_t) { PublishHeartbeat(); });
  loop.AddShutdownHook([this] {
    heartbeat_.SetState(heartbeat_t::STATE_STOPPING);
    heartbeat_.Publish();
  });
}

}  // namespace kestrel

#include "drivers/vicon/vicon_config.h"

#include <arpa/inet.h>

#include <cmath>
#include <set>
#include <stdexcept>

#include "common/check.h"
#include "common/config.h"

namespace kestrel {
namespace {

bool IsIpv4(const std::string& address, in_addr* out) {
  in_addr parsed{};
  if (inet_pton(AF_INET, address.c_str(), &parsed) != 1) return false;
  if (out != nullptr) *out = parsed;
  return true;
}

bool ValidObjectName(const std::string& name) {
  if (name.empty() || name.size() >= kViconNameBytes) return false;
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) return false;
  }
  return true;
}

bool InHalfOpen(double v, double hi) { return std::isfinite(v) && v > 0.0 && v <= hi; }

}  // namespace

bool IsLoopbackAddress(const std::string& address) {
  in_addr parsed{};
  if (!IsIpv4(address, &parsed)) return false;
  return (ntohl(parsed.s_addr) >> 24) == 127;
}

void ViconConfig::Validate() const {
  KESTREL_THROW_UNLESS(IsIpv4(bind_address, nullptr), "vicon.bind_address = '"
                                                          << bind_address
                                                          << "', accepted a dotted IPv4 address");
  KESTREL_THROW_UNLESS(port >= 0 && port <= 65535,
                       "vicon.port = " << port << ", accepted [0, 65535]");
  KESTREL_THROW_UNLESS(!objects.empty(), "vicon.objects is empty, accepted at least one object");
  std::set<std::string> names;
  for (size_t i = 0; i < objects.size(); ++i) {
    const ViconObjectConfig& o = objects[i];
    KESTREL_THROW_UNLESS(ValidObjectName(o.name), "vicon.objects["
                                                      << i << "].name = '" << o.name
                                                      << "', accepted 1..23 printable bytes");
    KESTREL_THROW_UNLESS(names.insert(o.name).second,
                         "vicon.objects[" << i << "].name = '" << o.name << "' appears twice");
    KESTREL_THROW_UNLESS(!o.channel.empty(),
                         "vicon.objects[" << i << "].channel is empty, accepted a channel name");
  }
  KESTREL_THROW_UNLESS(!frame_id.empty(), "vicon.frame_id is empty");
  KESTREL_THROW_UNLESS(std::isfinite(latency_s) && latency_s >= 0.0 && latency_s <= 1.0,
                       "vicon.latency_s = " << latency_s << ", accepted [0, 1]");
  KESTREL_THROW_UNLESS(InHalfOpen(timeout_s, 10.0),
                       "vicon.timeout_s = " << timeout_s << ", accepted (0, 10]");
  KESTREL_THROW_UNLESS(
      InHalfOpen(invalid_repeat_period_s, 10.0),
      "vicon.invalid_repeat_period_s = " << invalid_repeat_period_s << ", accepted (0, 10]");
  KESTREL_THROW_UNLESS(InHalfOpen(check_period_s, 1.0),
                       "vicon.check_period_s = " << check_period_s << ", accepted (0, 1]");
  KESTREL_THROW_UNLESS(max_frame_gap >= 1,
                       "vicon.max_frame_gap = " << max_frame_gap << ", accepted >= 1");
  KESTREL_THROW_UNLESS(
      reorder_window_frames >= 0 && reorder_window_frames < (int64_t{1} << 30),
      "vicon.reorder_window_frames = " << reorder_window_frames << ", accepted [0, 2^30)");
  KESTREL_THROW_UNLESS(
      euler_order == "xyz_intrinsic" || euler_order == "xyz_extrinsic",
      "vicon.euler_order = '" << euler_order << "', accepted xyz_intrinsic or xyz_extrinsic");
  KESTREL_THROW_UNLESS(!heartbeat_channel.empty(), "vicon.heartbeat_channel is empty");
  KESTREL_THROW_UNLESS(InHalfOpen(heartbeat_period_s, 1.0),
                       "vicon.heartbeat_period_s = " << heartbeat_period_s << ", accepted (0, 1]");
}

ViconEulerOrder ViconConfig::euler_order_enum() const {
  return euler_order == "xyz_extrinsic" ? ViconEulerOrder::kExtrinsicXyz
                                        : ViconEulerOrder::kIntrinsicXyz;
}

ViconConfig LoadViconConfig(const ConfigNode& node) {
  ViconConfig config;
  node.Read("bind_address", &config.bind_address);
  node.Read("port", &config.port, Range::Closed(0, 65535));
  if (node.Has("objects")) {
    config.objects.clear();
    for (const ConfigNode& element : node.Elements("objects")) {
      ViconObjectConfig object;
      element.ReadRequired("name", &object.name);
      element.Read("channel", &object.channel);
      element.Read("child_frame_id", &object.child_frame_id);
      config.objects.push_back(object);
    }
  }
  node.Read("frame_id", &config.frame_id);
  node.Read("latency_s", &config.latency_s, Range::Closed(0.0, 1.0));
  node.Read("timeout_s", &config.timeout_s, Range{0.0, 10.0, false, true});
  node.Read("invalid_repeat_period_s", &config.invalid_repeat_period_s,
            Range{0.0, 10.0, false, true});
  node.Read("check_period_s", &config.check_period_s, Range{0.0, 1.0, false, true});
  node.Read("max_frame_gap", &config.max_frame_gap, Range::AtLeast(1));
  node.Read("reorder_window_frames", &config.reorder_window_frames, Range::Closed(0, 1 << 29));
  node.Read("euler_order", &config.euler_order,
            std::vector<std::string>{"xyz_intrinsic", "xyz_extrinsic"});
  node.Read("allow_zero_padding", &config.allow_zero_padding);
  node.Read("zero_pose_is_occluded", &config.zero_pose_is_occluded);
  node.Read("heartbeat_channel", &config.heartbeat_channel);
  node.Read("heartbeat_period_s", &config.heartbeat_period_s, Range{0.0, 1.0, false, true});
  try {
    config.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return config;
}

void ViconEmitterConfig::Validate() const {
  KESTREL_THROW_UNLESS(IsLoopbackAddress(destination_address),
                       "vicon_emitter.destination_address = '"
                           << destination_address
                           << "', accepted a loopback IPv4 address (127.0.0.0/8) only");
  KESTREL_THROW_UNLESS(port >= 1 && port <= 65535,
                       "vicon_emitter.port = " << port << ", accepted [1, 65535]");
  KESTREL_THROW_UNLESS(
      source == "synthetic" || source == "sim_truth",
      "vicon_emitter.source = '" << source << "', accepted synthetic or sim_truth");
  KESTREL_THROW_UNLESS(!truth_channel.empty(), "vicon_emitter.truth_channel is empty");
  KESTREL_THROW_UNLESS(ValidObjectName(object_name), "vicon_emitter.object_name = '"
                                                         << object_name
                                                         << "', accepted 1..23 printable bytes");
  KESTREL_THROW_UNLESS(InHalfOpen(rate_hz, 1000.0),
                       "vicon_emitter.rate_hz = " << rate_hz << ", accepted (0, 1000]");
  KESTREL_THROW_UNLESS(
      first_frame_number >= 0 && first_frame_number <= int64_t{0xffffffff},
      "vicon_emitter.first_frame_number = " << first_frame_number << ", accepted [0, 2^32 - 1]");
  KESTREL_THROW_UNLESS(std::isfinite(radius_m) && radius_m >= 0.0 && radius_m <= 100.0,
                       "vicon_emitter.radius_m = " << radius_m << ", accepted [0, 100]");
  KESTREL_THROW_UNLESS(
      center_m.allFinite() && center_m.cwiseAbs().maxCoeff() <= 1000.0,
      "vicon_emitter.center_m = [" << center_m.transpose() << "], accepted each in [-1000, 1000]");
  KESTREL_THROW_UNLESS(
      std::isfinite(angular_rate_radps) && std::abs(angular_rate_radps) <= 100.0,
      "vicon_emitter.angular_rate_radps = " << angular_rate_radps << ", accepted [-100, 100]");
  KESTREL_THROW_UNLESS(std::isfinite(roll_rad) && std::abs(roll_rad) <= 1.5,
                       "vicon_emitter.roll_rad = " << roll_rad << ", accepted [-1.5, 1.5]");
  KESTREL_THROW_UNLESS(!heartbeat_channel.empty(), "vicon_emitter.heartbeat_channel is empty");
}

ViconEmitterConfig LoadViconEmitterConfig(const ConfigNode& node) {
  ViconEmitterConfig config;
  node.Read("destination_address", &config.destination_address);
  node.Read("port", &config.port, Range::Closed(1, 65535));
  node.Read("source", &config.source, std::vector<std::string>{"synthetic", "sim_truth"});
  node.Read("truth_channel", &config.truth_channel);
  node.Read("object_name", &config.object_name);
  node.Read("rate_hz", &config.rate_hz, Range{0.0, 1000.0, false, true});
  node.Read("first_frame_number", &config.first_frame_number, Range::Closed(0, 4294967295.0));
  node.Read("radius_m", &config.radius_m, Range::Closed(0.0, 100.0));
  node.Read("center_m", &config.center_m, Range::Closed(-1000.0, 1000.0));
  node.Read("angular_rate_radps", &config.angular_rate_radps, Range::Closed(-100.0, 100.0));
  node.Read("roll_rad", &config.roll_rad, Range::Closed(-1.5, 1.5));
  node.Read("heartbeat_channel", &config.heartbeat_channel);
  try {
    config.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(node.file() + ": " + e.what());
  }
  return config;
}

}  // namespace kestrel

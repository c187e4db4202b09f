#include "drivers/motors/motors_node.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "common/check.h"
#include "common/config.h"

namespace kestrel {

void MotorsConfig::Validate() const {
  KESTREL_THROW_UNLESS(ParseBlCtrlVersion(protocol).has_value(),
                       "motors.protocol = '" << protocol << "': blctrl_v1 or blctrl_v2");
  KESTREL_THROW_UNLESS(addresses.size() == 4,
                       "motors.addresses: " << addresses.size() << " given, one per rotor (4)");
  for (const int a : addresses) {
    KESTREL_THROW_UNLESS(a >= 0x08 && a <= 0x77,
                         "motors.addresses: " << a << " is not a 7-bit device address 0x08..0x77");
  }
  KESTREL_THROW_UNLESS(!bus.empty() && !channel.empty() && !heartbeat_channel.empty(),
                       "motors: bus, channel and heartbeat_channel must be set");
  KESTREL_THROW_UNLESS(command_timeout_s > 0.0 && command_timeout_s <= 5.0,
                       "motors.command_timeout_s = " << command_timeout_s << ": (0, 5]");
  KESTREL_THROW_UNLESS(refresh_hz >= 10.0 && refresh_hz <= 1000.0,
                       "motors.refresh_hz = " << refresh_hz << ": [10, 1000]");
  KESTREL_THROW_UNLESS(status_hz >= 0.0 && status_hz <= refresh_hz,
                       "motors.status_hz = " << status_hz << ": [0, refresh_hz]");
  ReopenBackoff::Validate(reopen_backoff_min_s, reopen_backoff_max_s, "motors");
  KESTREL_THROW_UNLESS(heartbeat_period_s > 0.0 && heartbeat_period_s <= 10.0,
                       "motors.heartbeat_period_s = " << heartbeat_period_s << ": (0, 10]");
  realtime.Validate();
}

MotorsConfig LoadMotorsConfig(const ConfigNode& root) {
  MotorsConfig c;
  root.Read("bus", &c.bus);
  root.Read("protocol", &c.protocol, std::vector<std::string>{"blctrl_v1", "blctrl_v2"});
  if (root.Has("addresses")) {
    std::vector<double> addresses;
    root.Read("addresses", &addresses, Range::Closed(0x08, 0x77));
    c.addresses.clear();
    for (const double a : addresses) c.addresses.push_back(static_cast<int>(a));
  }
  root.Read("channel", &c.channel);
  root.Read("heartbeat_channel", &c.heartbeat_channel);
  root.Read("command_timeout_s", &c.command_timeout_s, Range{0.0, 5.0, false, true});
  root.Read("refresh_hz", &c.refresh_hz, Range::Closed(10.0, 1000.0));
  root.Read("status_hz", &c.status_hz, Range::Closed(0.0, 1000.0));
  root.Read("reopen_backoff_min_s", &c.reopen_backoff_min_s, Range::Positive());
  root.Read("reopen_backoff_max_s", &c.reopen_backoff_max_s, Range::Positive());
  root.Read("heartbeat_period_s", &c.heartbeat_period_s, Range{0.0, 10.0, false, true});
  c.realtime = ReadRealtimeConfig(root);
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(root.file() + ": " + e.what());
  }
  return c;
}

MotorsNode::MotorsNode(lcm::LCM& lcm, const MotorsConfig& config, const EscMap& map,
                       const Clock& clock, I2cBusOpener open_bus)
    : lcm_(lcm),
      config_(config),
      map_(map),
      version_(BlCtrlVersion::kV2),
      clock_(clock),
      open_bus_(std::move(open_bus)),
      heartbeat_(lcm, clock, "kestrel-motors", config.heartbeat_channel),
      drops_(clock),
      subscriptions_(lcm),
      set_points_(config.addresses.size(), 0),
      thrust_N_(config.addresses.size(), 0.0),
      status_(config.addresses.size()),
      reopen_(config.reopen_backoff_min_s, config.reopen_backoff_max_s, "motors") {
  config_.Validate();
  version_ = *ParseBlCtrlVersion(config_.protocol);
  subscriptions_.Add<motor_command_t>(
      config_.channel, [this](const std::string&, const motor_command_t& m) { OnCommand(m); },
      [this](const std::string& channel, const std::string& reason) {
        drops_.Count("malformed", channel + ": " + reason);
      });
}

MotorsNode::~MotorsNode() {
  if (bus_ != nullptr) Write(std::vector<int>(set_points_.size(), 0));
}

void MotorsNode::OnCommand(const motor_command_t& msg) {
  if (msg.num_motors != static_cast<int32_t>(set_points_.size())) {
    drops_.Count("wrong_motor_count", std::to_string(msg.num_motors) + " rotors, the vehicle has " +
                                          std::to_string(set_points_.size()));
    return;
  }
  for (const double t : msg.thrust_N) {
    if (!std::isfinite(t)) {
      drops_.Count("non_finite", "a rotor thrust that is not a finite number");
      return;
    }
  }
  ++commands_;
  const int64_t now = clock_.NowUtime();
  last_command_utime_ = now;
  armed_ = msg.armed;
  if (msg.armed) ever_armed_since_open_ = true;
  thrust_N_ = msg.thrust_N;
  if (watchdog_tripped_ && msg.armed) {
    watchdog_tripped_ = false;
    Log(LogLevel::kInfo, "commands again: the motors follow the controller");
  }
  if (bus_ == nullptr || watchdog_tripped_) return;
  std::vector<int> set_points(set_points_.size());
  for (size_t i = 0; i < set_points.size(); ++i) {
    set_points[i] =
        ThrustToBlCtrlSetPoint(map_, version_, thrust_N_[i], armed_ && ever_armed_since_open_);
  }
  if (Write(set_points)) command_to_write_.Record(clock_.NowUtime() - msg.utime);
}

bool MotorsNode::Write(const std::vector<int>& set_points) {
  if (bus_ == nullptr) return false;
  std::vector<I2cMessage> transfer;
  for (size_t i = 0; i < set_points.size(); ++i) {
    transfer.push_back(I2cMessage{static_cast<uint8_t>(config_.addresses[i]), false,
                                  EncodeBlCtrlSetPoint(version_, set_points[i])});
  }
  std::string error;
  if (!bus_->Transfer(&transfer, &error)) {
    BusFailed(error);
    return false;
  }
  set_points_ = set_points;
  ++writes_;
  return true;
}

void MotorsNode::BusFailed(const std::string& error) {
  ++bus_errors_;
  last_error_ = error;
  fault_ = true;
  Log(LogLevel::kError, "bus error, motors off: " + error);
  // Zeros, once, on what is left of the bus; then closed and reopened with back-off.
  std::vector<I2cMessage> zeros;
  for (size_t i = 0; i < set_points_.size(); ++i) {
    zeros.push_back(I2cMessage{static_cast<uint8_t>(config_.addresses[i]), false,
                               EncodeBlCtrlSetPoint(version_, 0)});
  }
  std::string ignored;
  bus_->Transfer(&zeros, &ignored);
  std::fill(set_points_.begin(), set_points_.end(), 0);
  bus_.reset();
  ever_armed_since_open_ = false;
  reopen_.Failed(clock_.NowUtime());
}

void MotorsNode::Refresh() {
  const int64_t now = clock_.NowUtime();
  if (bus_ == nullptr) {
    if (!reopen_.Due(now)) return;
    try {
      bus_ = open_bus_(config_.bus);
      ++reopens_;
      reopen_.Succeeded();
      ever_armed_since_open_ = false;
      Log(LogLevel::kInfo, "bus " + bus_->name() + " open");
    } catch (const std::exception& e) {
      last_error_ = e.what();
      drops_.Count("bus_open", e.what());
      reopen_.Failed(now);
      return;
    }
  }
  const bool stale = last_command_utime_ < 0 ||
                     now - last_command_utime_ > SecondsToUtime(config_.command_timeout_s);
  if (stale && armed_ && !watchdog_tripped_) {
    watchdog_tripped_ = true;
    ++watchdog_trips_;
    armed_ = false;
    Log(LogLevel::kError, "watchdog: no motor command for " +
                              std::to_string(config_.command_timeout_s) + " s, motors off");
  }
  std::vector<int> set_points(set_points_.size(), 0);
  if (!watchdog_tripped_ && !stale) {
    for (size_t i = 0; i < set_points.size(); ++i) {
      set_points[i] =
          ThrustToBlCtrlSetPoint(map_, version_, thrust_N_[i], armed_ && ever_armed_since_open_);
    }
  }
  if (!Write(set_points)) return;
  fault_ = false;
  if (config_.status_hz > 0.0 && now >= next_status_utime_ && bus_ != nullptr) {
    next_status_utime_ = now + SecondsToUtime(1.0 / config_.status_hz);
    for (size_t i = 0; i < status_.size(); ++i) {
      std::vector<I2cMessage> read{
          I2cMessage{static_cast<uint8_t>(config_.addresses[i]), true, std::vector<uint8_t>(3, 0)}};
      std::string error;
      if (!bus_->Transfer(&read, &error)) {
        BusFailed(error);
        return;
      }
      const auto status = DecodeBlCtrlStatus(read[0].data);
      if (status.has_value()) status_[i] = *status;
    }
  }
}

void MotorsNode::PublishHeartbeat() {
  heartbeat_.SetState(fault_ || bus_ == nullptr ? heartbeat_t::STATE_FAILED
                      : watchdog_tripped_       ? heartbeat_t::STATE_DEGRADED
                                                : heartbeat_t::STATE_OK);
  heartbeat_.SetValue("armed", armed_ ? 1.0 : 0.0);
  heartbeat_.SetValue("watchdog_tripped", watchdog_tripped_ ? 1.0 : 0.0);
  heartbeat_.SetValue("commands", static_cast<double>(commands_));
  heartbeat_.SetValue("writes", static_cast<double>(writes_));
  heartbeat_.SetValue("bus_errors", static_cast<double>(bus_errors_));
  heartbeat_.SetValue("bus_opens", static_cast<double>(reopens_));
  heartbeat_.SetValue("watchdog_trips", static_cast<double>(watchdog_trips_));
  for (size_t i = 0; i < set_points_.size(); ++i) {
    heartbeat_.SetValue("set_point_" + std::to_string(i + 1), set_points_[i]);
    heartbeat_.SetValue("current_A_" + std::to_string(i + 1), status_[i].current_A);
  }
  heartbeat_.SetValue("command_to_write_p50_us",
                      static_cast<double>(command_to_write_.QuantileUs(0.5)));
  heartbeat_.SetValue("command_to_write_max_us", static_cast<double>(command_to_write_.max_us()));
  heartbeat_.SetDropValues(drops_);
  heartbeat_.SetLastError(last_error_.empty() ? drops_.last_reason() : last_error_);
  heartbeat_.Publish();
}

}  // namespace kestrel

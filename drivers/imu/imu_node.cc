#include "drivers/imu/imu_node.h"

#include <poll.h>

#include <algorithm>

#include "common/check.h"
#include "common/config.h"
#include "common/identity.h"
#include "kestrel/imu_t.hpp"

namespace kestrel {

void ImuConfig::Validate() const {
  KESTREL_THROW_UNLESS(!port.empty(), "imu.port must be set");
  KESTREL_THROW_UNLESS(async_mode >= 1 && async_mode <= 3,
                       "imu.async_mode = " << async_mode << ": 1, 2 or 3");
  KESTREL_THROW_UNLESS(rate_divisor >= 1 && rate_divisor <= 800,
                       "imu.rate_divisor = " << rate_divisor << ": 1..800 (800 Hz / divisor)");
  KESTREL_THROW_UNLESS(!channel.empty() && !heartbeat_channel.empty(),
                       "imu: channel and heartbeat_channel must be set");
  KESTREL_THROW_UNLESS(reply_timeout_s > 0.0 && frame_timeout_s > 0.0 && clock_window_s > 0.0,
                       "imu: reply_timeout_s, frame_timeout_s and clock_window_s must be > 0");
  KESTREL_THROW_UNLESS(command_retries >= 0, "imu.command_retries = " << command_retries);
  ReopenBackoff::Validate(reopen_backoff_min_s, reopen_backoff_max_s, "imu");
  KESTREL_THROW_UNLESS(heartbeat_period_s > 0.0 && heartbeat_period_s <= 10.0,
                       "imu.heartbeat_period_s = " << heartbeat_period_s << ": (0, 10]");
  realtime.Validate();
}

ImuConfig LoadImuConfig(const ConfigNode& root) {
  ImuConfig c;
  root.Read("port", &c.port);
  root.Read("baud", &c.baud, Range::Closed(9600, 921600));
  root.Read("async_mode", &c.async_mode, Range::Closed(1, 3));
  root.Read("rate_divisor", &c.rate_divisor, Range::Closed(1, 800));
  root.Read("channel", &c.channel);
  root.Read("sensor_name", &c.sensor_name);
  root.Read("heartbeat_channel", &c.heartbeat_channel);
  root.Read("reply_timeout_s", &c.reply_timeout_s, Range::Positive());
  root.Read("command_retries", &c.command_retries, Range::Closed(0, 10));
  root.Read("frame_timeout_s", &c.frame_timeout_s, Range::Positive());
  root.Read("reopen_backoff_min_s", &c.reopen_backoff_min_s, Range::Positive());
  root.Read("reopen_backoff_max_s", &c.reopen_backoff_max_s, Range::Positive());
  root.Read("clock_window_s", &c.clock_window_s, Range::Positive());
  root.Read("heartbeat_period_s", &c.heartbeat_period_s, Range{0.0, 10.0, false, true});
  c.realtime = ReadRealtimeConfig(root);
  try {
    c.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(root.file() + ": " + e.what());
  }
  return c;
}

int64_t MinimumLatencyClock::Stamp(int64_t device_us, int64_t arrival_utime) {
  if (last_device_us_ >= 0 && device_us < last_device_us_) {
    samples_.clear();
    ++restarts_;
    last_stamp_utime_ = 0;
  }
  last_device_us_ = device_us;
  const int64_t latency = arrival_utime - device_us;
  // A monotone queue: the front holds the window's minimum.
  while (!samples_.empty() && samples_.back().second >= latency) samples_.pop_back();
  samples_.emplace_back(device_us, latency);
  while (samples_.front().first < device_us - window_us_) samples_.pop_front();
  // Never back, never equal: where the minimum just fell by more than the sample spacing (the
  // first samples of a stream, a burst after a stall), the stamp is the previous one's + 1 us.
  last_stamp_utime_ = std::max(device_us + samples_.front().second, last_stamp_utime_ + 1);
  return last_stamp_utime_;
}

ImuNode::ImuNode(lcm::LCM& lcm, const ImuConfig& config, const Clock& clock)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      heartbeat_(lcm, clock, "kestrel-imu", config.heartbeat_channel),
      drops_(clock),
      mapping_(SecondsToUtime(config.clock_window_s)),
      reopen_(config.reopen_backoff_min_s, config.reopen_backoff_max_s, "imu"),
      epoch_(NewPublisherEpoch()) {
  config_.Validate();
}

void ImuNode::Close(const std::string& why) {
  if (port_ != nullptr) {
    last_error_ = why;
    drops_.Count("reopen", why);
  }
  port_.reset();
  parser_.Reset();
  mapping_.Reset();
  state_ = State::kClosed;
  reopen_.Failed(clock_.NowUtime());
}

void ImuNode::SendCommand() {
  const std::string body = state_ == State::kAsciiOff
                               ? std::string("WRG,06,0")
                               : Vn100BinaryOutputBody(config_.async_mode, config_.rate_divisor);
  expected_echo_ = "VN" + body;
  command_deadline_utime_ = clock_.NowUtime() + SecondsToUtime(config_.reply_timeout_s);
  const IoResult r = port_->Write(Vn100Command(body), 100);
  if (r.status != IoStatus::kOk) Close(std::string("write: ") + ToString(r.status));
}

void ImuNode::Poll(int timeout_ms) {
  int64_t now = clock_.NowUtime();
  if (state_ == State::kClosed) {
    if (!reopen_.Due(now)) {
      ::poll(nullptr, 0,
             std::min<int>(timeout_ms, static_cast<int>((reopen_.next_utime() - now) / 1000) + 1));
      return;
    }
    try {
      SerialOptions options;
      options.baud = config_.baud;
      port_ = std::make_unique<SerialPort>(config_.port, options);
    } catch (const SerialError& e) {
      last_error_ = e.what();
      drops_.Count("open", e.what());
      reopen_.Failed(now);
      return;
    }
    ++opens_;
    Log(LogLevel::kInfo, "opened " + config_.port + "; configuring the binary output");
    state_ = State::kAsciiOff;
    retries_left_ = config_.command_retries;
    SendCommand();
    return;
  }
  std::string bytes;
  const IoResult r = port_->Read(&bytes, 4096, timeout_ms);
  now = clock_.NowUtime();
  if (r.status == IoStatus::kDisconnected || r.status == IoStatus::kError) {
    Close(std::string("read: ") + ToString(r.status));
    return;
  }
  for (const Vn100Message& m : parser_.Feed(bytes)) {
    Handle(m, now);
    if (state_ == State::kClosed) return;
  }
  CountParserDrops();
  if (state_ == State::kStreaming) {
    if (now - last_frame_utime_ > SecondsToUtime(config_.frame_timeout_s)) {
      drops_.Count("stall", "no frame for " + std::to_string(config_.frame_timeout_s) + " s");
      Close("stall");
    }
  } else if (now > command_deadline_utime_) {
    if (retries_left_-- > 0) {
      drops_.Count("no_reply", "no echo of $" + expected_echo_ + "; sending it again");
      SendCommand();
    } else {
      Close("no reply to $" + expected_echo_);
    }
  }
}

void ImuNode::Handle(const Vn100Message& m, int64_t arrival_utime) {
  if (m.kind == Vn100Message::Kind::kAscii) {
    if (m.ascii.rfind("VNERR", 0) == 0) {
      drops_.Count("device_error", "$" + m.ascii + " in reply to $" + expected_echo_);
      if (state_ != State::kStreaming) Close("the device refused $" + expected_echo_);
      return;
    }
    if (state_ != State::kStreaming && m.ascii == expected_echo_) {
      state_ = state_ == State::kAsciiOff ? State::kBinaryOutput : State::kStreaming;
      retries_left_ = config_.command_retries;
      if (state_ == State::kBinaryOutput) {
        SendCommand();
      } else {
        last_frame_utime_ = arrival_utime;
        reopen_.Succeeded();
        Log(LogLevel::kInfo, "streaming " + std::to_string(800 / config_.rate_divisor) + " Hz");
      }
    }
    return;  // asynchronous ASCII lines before register 06 took effect
  }
  if (state_ != State::kStreaming) return;  // frames of an older configuration
  last_frame_utime_ = arrival_utime;
  const auto device_us = static_cast<int64_t>(m.sample.time_startup_ns / 1000);
  imu_t msg{};
  msg.utime = mapping_.Stamp(device_us, arrival_utime);
  msg.seq = seq_++;
  msg.epoch = epoch_;
  msg.sensor_name = config_.sensor_name;
  const std::array<double, 3> w = Vn100ToBody(m.sample.angular_rate_radps);
  const std::array<double, 3> a = Vn100ToBody(m.sample.accel_mps2);
  for (int k = 0; k < 3; ++k) {
    msg.angular_velocity_radps[k] = w[k];
    msg.specific_force_mps2[k] = a[k];
  }
  lcm_.publish(config_.channel, &msg);
  ++published_;
  sample_to_publish_.Record(clock_.NowUtime() - msg.utime);
}

void ImuNode::CountParserDrops() {
  for (const auto& [reason, count] : parser_.drops()) {
    int64_t& seen = parser_drops_seen_[reason];
    for (; seen < count; ++seen) drops_.Count(reason, "VN-100 stream: " + reason);
  }
}

void ImuNode::PublishHeartbeat() {
  heartbeat_.SetState(state_ == State::kStreaming ? heartbeat_t::STATE_OK
                      : opens_ == 0               ? heartbeat_t::STATE_STARTING
                                                  : heartbeat_t::STATE_DEGRADED);
  heartbeat_.SetValue("frames", static_cast<double>(parser_.frames()));
  heartbeat_.SetValue("published", static_cast<double>(published_));
  heartbeat_.SetValue("opens", static_cast<double>(opens_));
  heartbeat_.SetValue("clock_offset_us", static_cast<double>(mapping_.offset_us()));
  heartbeat_.SetValue("clock_restarts", static_cast<double>(mapping_.restarts()));
  heartbeat_.SetValue("sample_to_publish_p50_us",
                      static_cast<double>(sample_to_publish_.QuantileUs(0.5)));
  heartbeat_.SetValue("sample_to_publish_max_us", static_cast<double>(sample_to_publish_.max_us()));
  heartbeat_.SetDropValues(drops_);
  heartbeat_.SetLastError(last_error_.empty() ? drops_.last_reason() : last_error_);
  heartbeat_.Publish();
}

}  // namespace kestrel

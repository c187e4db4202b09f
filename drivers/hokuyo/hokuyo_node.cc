#include "drivers/hokuyo/hokuyo_node.h"

#include <algorithm>
#include <limits>

#include <time.h>

#include "common/identity.h"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/planar_scan_t.hpp"

namespace kestrel {

HokuyoNode::HokuyoNode(lcm::LCM& lcm, const HokuyoConfig& config, Clock& clock)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      driver_(config),
      heartbeat_(lcm, clock, "kestrel-hokuyo", config.heartbeat_channel),
      drops_(clock),
      backoff_s_(config.reopen_backoff_min_s),
      epoch_(NewPublisherEpoch()) {
  rate_window_start_utime_ = clock_.NowUtime();
}

void HokuyoNode::TryOpen(int64_t now_utime) {
  SerialOptions options;
  options.baud = config_.baud;
  try {
    port_ = std::make_unique<SerialPort>(config_.port, options);
  } catch (const SerialError& e) {
    drops_.Count("open_failed", e.what());
    last_error_ = e.what();
    next_open_utime_ = now_utime + SecondsToUtime(backoff_s_);
    backoff_s_ = std::min(2.0 * backoff_s_, config_.reopen_backoff_max_s);
    return;
  }
  ++opens_;
  Log(LogLevel::kInfo, "opened " + config_.port);
  driver_.Start(clock_.NowUtime());
  WriteOutput();
}

void HokuyoNode::Close(const std::string& reason, int64_t now_utime) {
  port_.reset();
  driver_.Stop();
  last_error_ = reason;
  Log(LogLevel::kWarning, "closed " + config_.port + ": " + reason + "; reopening in " +
                              std::to_string(backoff_s_) + " s");
  next_open_utime_ = now_utime + SecondsToUtime(backoff_s_);
  backoff_s_ = std::min(2.0 * backoff_s_, config_.reopen_backoff_max_s);
}

void HokuyoNode::WriteOutput() {
  const std::string bytes = driver_.TakeOutput();
  if (bytes.empty() || port_ == nullptr) return;
  // The sensor cannot read the command before write() starts: that bounds its TM1 clock read.
  const int64_t write_start_utime = clock_.NowUtime();
  const IoResult r = port_->Write(bytes, 200);
  if (r.status != IoStatus::kOk) {
    drops_.Count("write_failed", ToString(r.status));
    Close(std::string("write ") + ToString(r.status), clock_.NowUtime());
    return;
  }
  driver_.OnWritten(write_start_utime);
}

void HokuyoNode::CollectEvents() {
  for (const HokuyoDriverEvent& e : driver_.TakeEvents()) {
    drops_.Count(e.kind, e.reason);
    last_error_ = e.kind + ": " + e.reason;
  }
}

void HokuyoNode::PublishScans() {
  for (HokuyoScan& scan : driver_.TakeScans()) {
    planar_scan_t msg;
    msg.utime = scan.utime;
    msg.seq = seq_++;
    msg.epoch = epoch_;
    msg.sensor_name = config_.sensor_name;
    msg.angle_min_rad = scan.angle_min_rad;
    msg.angle_step_rad = scan.angle_step_rad;
    msg.time_step_s = scan.time_step_s;
    msg.range_min_m = scan.range_min_m;
    msg.range_max_m = scan.range_max_m;
    msg.num_ranges = static_cast<int32_t>(scan.ranges_m.size());
    msg.ranges_m = std::move(scan.ranges_m);
    msg.num_intensities = static_cast<int32_t>(scan.intensities.size());
    msg.intensities = std::move(scan.intensities);
    lcm_.publish(config_.channel, &msg);
    ++scans_published_;
    ++rate_window_scans_;
    backoff_s_ = config_.reopen_backoff_min_s;  // streaming again: the next fault starts afresh
  }
}

void HokuyoNode::Poll(int timeout_ms) {
  int64_t now = clock_.NowUtime();
  if (port_ == nullptr) {
    if (now >= next_open_utime_) {
      TryOpen(now);
    } else {
      const int64_t wait_us = std::min<int64_t>(next_open_utime_ - now, timeout_ms * 1000LL);
      struct timespec ts {
        static_cast<time_t>(wait_us / 1000000), static_cast<long>((wait_us % 1000000) * 1000)
      };
      nanosleep(&ts, nullptr);
    }
    CollectEvents();
    return;
  }
  const int64_t deadline = driver_.next_deadline_utime();
  int64_t wait_ms = timeout_ms;
  if (deadline != std::numeric_limits<int64_t>::max()) {
    wait_ms = std::clamp<int64_t>((deadline - now + 999) / 1000, 0, timeout_ms);
  }
  std::string bytes;
  const IoResult r = port_->Read(&bytes, 8192, static_cast<int>(wait_ms));
  now = clock_.NowUtime();
  if (r.status == IoStatus::kOk) {
    driver_.OnBytes(bytes, now);
  } else if (r.status == IoStatus::kDisconnected || r.status == IoStatus::kError) {
    drops_.Count("disconnected", std::string("read ") + ToString(r.status));
    CollectEvents();
    Close(std::string("read ") + ToString(r.status) + " (device gone?)", now);
    return;
  }
  driver_.OnTick(now);
  WriteOutput();
  PublishScans();
  CollectEvents();
  if (port_ != nullptr && driver_.needs_reopen()) Close(driver_.reopen_reason(), now);
}

void HokuyoNode::PublishHeartbeat() {
  const int64_t now = clock_.NowUtime();
  const double window_s = UtimeToSeconds(now - rate_window_start_utime_);
  if (window_s > 0.0) scan_rate_hz_ = static_cast<double>(rate_window_scans_) / window_s;
  rate_window_start_utime_ = now;
  rate_window_scans_ = 0;
  const bool streaming = port_ != nullptr && driver_.state() == HokuyoDriver::State::kStreaming;
  if (streaming) {
    heartbeat_.SetState(heartbeat_t::STATE_OK);
  } else if (opens_ == 0 && drops_.total() == 0) {
    heartbeat_.SetState(heartbeat_t::STATE_STARTING);
  } else {
    heartbeat_.SetState(heartbeat_t::STATE_DEGRADED);
  }
  heartbeat_.SetLastError(last_error_);
  heartbeat_.SetValue("scan_rate_hz", scan_rate_hz_);
  heartbeat_.SetValue("scans_published", static_cast<double>(scans_published_));
  heartbeat_.SetValue("port_opens", static_cast<double>(opens_));
  heartbeat_.SetValue("skipped_replies", static_cast<double>(driver_.skipped_replies()));
  heartbeat_.SetValue("clock_offset_ms", driver_.clock().offset_us() * 1e-3);
  heartbeat_.SetValue("clock_drift_ppm", driver_.clock().drift_ppm());
  heartbeat_.SetValue("tm_min_round_trip_ms",
                      static_cast<double>(driver_.clock().min_round_trip_us()) * 1e-3);
  heartbeat_.SetValue("drops_total", static_cast<double>(drops_.total()));
  for (const auto& [kind, count] : drops_.counts()) {
    heartbeat_.SetValue("drops_" + kind, static_cast<double>(count));
  }
  heartbeat_.Publish();
}

int HokuyoNode::Run(NodeLoop& loop) {
  loop.AddTimer("heartbeat", SecondsToUtime(config_.heartbeat_period_s),
                [this](int64_t) { PublishHeartbeat(); });
  loop.AddShutdownHook([this] {
    heartbeat_.SetState(heartbeat_t::STATE_STOPPING);
    heartbeat_.Publish();
  });
  NodeLoop::InstallSignalHandlers();
  while (!NodeLoop::signal_received()) {
    Poll(10);
    if (!loop.RunOnce(0)) return 1;
  }
  if (port_ != nullptr && driver_.state() == HokuyoDriver::State::kStreaming) {
    port_->Write(scip::EncodeCommand("QT"), 100);  // leave the laser off
  }
  return loop.Run();  // returns at once (signal received) after running the shutdown hooks
}

}  // namespace kestrel

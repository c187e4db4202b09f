#include "drivers/hokuyo/hokuyo_driver.h"

#include <cmath>
#include <limits>
#include <utility>

#include "common/clock.h"

namespace kestrel {
namespace {

bool ParseInt(const std::map<std::string, std::string>& params, const std::string& key,
              int* value) {
  const auto it = params.find(key);
  if (it == params.end() || it->second.empty() || it->second.size() > 9) return false;
  int v = 0;
  for (const char c : it->second) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  *value = v;
  return true;
}

}  // namespace

const char* ToString(HokuyoDriver::State state) {
  using S = HokuyoDriver::State;
  switch (state) {
    case S::kIdle:
      return "idle";
    case S::kProbing:
      return "probing";
    case S::kLeavingTimeAdjust:
      return "leaving time-adjust mode";
    case S::kStoppingStream:
      return "stopping stream";
    case S::kReadingParameters:
      return "reading parameters";
    case S::kReadingVersion:
      return "reading version";
    case S::kEnteringTimeAdjust:
      return "entering time-adjust mode";
    case S::kSyncingClock:
      return "syncing clock";
    case S::kLeavingTimeAdjustAfterSync:
      return "leaving time-adjust mode after sync";
    case S::kStartingStream:
      return "starting stream";
    case S::kStreaming:
      return "streaming";
  }
  return "unknown";
}

HokuyoDriver::HokuyoDriver(const HokuyoConfig& config)
    : config_(config),
      clock_(SecondsToUtime(config.drift_window_s), config.drift_windows,
             config.max_drift_ppm * 1e-6) {
  config_.Validate();
}

void HokuyoDriver::Start(int64_t now_utime) {
  parser_.Reset();
  unwrapper_.Reset();
  clock_.Reset();
  output_.clear();
  needs_reopen_ = false;
  reopen_reason_.clear();
  sync_samples_ = 0;
  next_sync_utime_ = -1;
  state_ = State::kProbing;
  Send("SCIP2.0", now_utime);
}

void HokuyoDriver::Stop() {
  state_ = State::kIdle;
  pending_.clear();
  output_.clear();
  parser_.Reset();
}

void HokuyoDriver::Send(const std::string& command, int64_t now_utime) {
  output_ += scip::EncodeCommand(command);
  pending_ = command;
  pending_send_utime_ = now_utime;
  deadline_utime_ = now_utime + SecondsToUtime(config_.reply_timeout_s);
  attempts_ = 0;
}

void HokuyoDriver::Resend(int64_t now_utime) {
  const int attempts = attempts_ + 1;
  Send(pending_, now_utime);
  attempts_ = attempts;
}

void HokuyoDriver::OnWritten(int64_t write_start_utime) {
  if (!pending_.empty()) pending_send_utime_ = write_start_utime;
}

void HokuyoDriver::RequestReopen(const std::string& reason) {
  if (needs_reopen_) return;
  needs_reopen_ = true;
  reopen_reason_ = reason;
  Count("reopen", reason);
  pending_.clear();
}

void HokuyoDriver::Count(const std::string& kind, const std::string& reason) {
  events_.push_back({kind, reason});
}

std::string HokuyoDriver::TakeOutput() { return std::exchange(output_, std::string()); }
std::vector<HokuyoScan> HokuyoDriver::TakeScans() { return std::exchange(scans_, {}); }
std::vector<HokuyoDriverEvent> HokuyoDriver::TakeEvents() { return std::exchange(events_, {}); }

int64_t HokuyoDriver::next_deadline_utime() const {
  if (state_ == State::kIdle || needs_reopen_) return std::numeric_limits<int64_t>::max();
  if (state_ == State::kStreaming) {
    return last_scan_utime_ + SecondsToUtime(config_.scan_timeout_s);
  }
  if (state_ == State::kSyncingClock && pending_.empty() && next_sync_utime_ >= 0) {
    return next_sync_utime_;
  }
  return pending_.empty() ? std::numeric_limits<int64_t>::max() : deadline_utime_;
}

void HokuyoDriver::OnTick(int64_t now_utime) {
  if (state_ == State::kIdle || needs_reopen_) return;
  if (state_ == State::kStreaming) {
    if (now_utime - last_scan_utime_ > SecondsToUtime(config_.scan_timeout_s)) {
      RequestReopen("no scan for " + std::to_string(config_.scan_timeout_s) + " s");
    }
    return;
  }
  if (state_ == State::kSyncingClock && pending_.empty() && next_sync_utime_ >= 0 &&
      now_utime >= next_sync_utime_) {
    next_sync_utime_ = -1;
    Send("TM1", now_utime);
    return;
  }
  if (!pending_.empty() && now_utime > deadline_utime_) {
    Count("timeout", "no reply to " + pending_);
    if (attempts_ < config_.command_retries) {
      Resend(now_utime);
    } else {
      RequestReopen("no reply to " + pending_ + " after " +
                    std::to_string(config_.command_retries + 1) + " tries");
    }
  }
}

void HokuyoDriver::OnBytes(std::string_view bytes, int64_t now_utime) {
  if (state_ == State::kIdle) return;
  parser_.Feed(bytes);
  while (!needs_reopen_) {
    const std::optional<scip::ParseEvent> event = parser_.Next();
    if (!event) break;
    if (!event->reply) {
      Count("scip_parse", std::string(scip::ToString(event->error)) + " (" +
                              std::to_string(event->discarded_bytes) + " bytes dropped)");
      continue;
    }
    HandleReply(*event->reply, now_utime);
  }
}

bool HokuyoDriver::MatchesPending(const scip::Reply& reply) const {
  if (pending_.empty()) return false;
  return reply.command_text() == pending_;
}

void HokuyoDriver::HandleReply(const scip::Reply& reply, int64_t now_utime) {
  if (state_ == State::kStreaming && reply.command_text() == stream_command_) {
    HandleScan(reply, now_utime);
    return;
  }
  if (state_ == State::kStreaming && scip::CharsPerRange(reply.command()) > 0 &&
      reply.status == "99") {
    HandleScan(reply, now_utime);  // the echo of a scan carries the remaining count
    return;
  }
  if (MatchesPending(reply)) {
    HandlePendingReply(reply, now_utime);
    return;
  }
  ++skipped_replies_;  // scans of a stream left running, late replies to a retried command
}

void HokuyoDriver::HandlePendingReply(const scip::Reply& reply, int64_t now_utime) {
  const std::string& s = reply.status;
  const auto fail = [&](const std::string& what) {
    Count("scip_status", pending_ + ": " + scip::DescribeStatus(reply.command(), s));
    RequestReopen(what + ": " + scip::DescribeStatus(reply.command(), s));
  };
  switch (state_) {
    case State::kProbing:
      // "0": switched from SCIP 1.1; "0E" (or "00"): already SCIP 2.0.
      if (s != "0" && s != "0E" && s != "00") return fail("SCIP2.0 refused");
      state_ = State::kLeavingTimeAdjust;
      Send("TM2", now_utime);
      return;
    case State::kLeavingTimeAdjust:
      if (s != "00" && s != "03") Count("scip_status", "TM2: " + scip::DescribeStatus("TM", s));
      state_ = State::kStoppingStream;
      Send("QT", now_utime);
      return;
    case State::kStoppingStream:
      if (s != "00") return fail("QT refused");
      state_ = State::kReadingParameters;
      Send("PP", now_utime);
      return;
    case State::kReadingParameters:
      if (s != "00") return fail("PP refused");
      if (!ReadParameters(reply)) return;
      state_ = State::kReadingVersion;
      Send("VV", now_utime);
      return;
    case State::kReadingVersion:
      if (s != "00") return fail("VV refused");
      version_ = scip::ParseParameters(reply);
      state_ = State::kEnteringTimeAdjust;
      Send("TM0", now_utime);
      return;
    case State::kEnteringTimeAdjust:
      if (s != "00" && s != "02") return fail("TM0 refused");
      state_ = State::kSyncingClock;
      Send("TM1", now_utime);
      return;
    case State::kSyncingClock: {
      if (s != "00") return fail("TM1 refused");
      const std::optional<uint32_t> t = scip::DecodeTimestamp(reply);
      if (!t) {
        Count("scip_decode", "TM1 time stamp malformed");
        Resend(now_utime);
        return;
      }
      clock_.AddSyncSample(pending_send_utime_, now_utime, unwrapper_.Unwrap(*t));
      if (++sync_samples_ < config_.clock_sync_samples) {
        if (config_.clock_sync_spacing_s <= 0.0) {
          Send("TM1", now_utime);
        } else {
          pending_.clear();  // OnTick sends the next TM1 after the pause
          next_sync_utime_ = now_utime + SecondsToUtime(config_.clock_sync_spacing_s);
        }
        return;
      }
      clock_.FinishSync();
      state_ = State::kLeavingTimeAdjustAfterSync;
      Send("TM2", now_utime);
      return;
    }
    case State::kLeavingTimeAdjustAfterSync: {
      if (s != "00" && s != "03") return fail("TM2 refused");
      scip::MeasureRequest r;
      r.command = config_.intensities ? "ME" : "MD";
      r.start_step = first_step_;
      r.end_step = last_step_;
      r.cluster_count = 1;
      r.scan_interval = config_.scan_skip;
      r.num_scans = 0;
      stream_command_ = scip::FormatMeasureCommand(r);
      state_ = State::kStartingStream;
      Send(stream_command_, now_utime);
      return;
    }
    case State::kStartingStream:
      if (s != "00") return fail(stream_command_.substr(0, 2) + " refused");
      pending_.clear();
      state_ = State::kStreaming;
      last_scan_utime_ = now_utime;
      return;
    case State::kIdle:
    case State::kStreaming:
      return;
  }
}

bool HokuyoDriver::ReadParameters(const scip::Reply& reply) {
  const std::map<std::string, std::string> p = scip::ParseParameters(reply);
  HokuyoModel m;
  const auto modl = p.find("MODL");
  const bool complete = modl != p.end() && ParseInt(p, "DMIN", &m.dmin_mm) &&
                        ParseInt(p, "DMAX", &m.dmax_mm) && ParseInt(p, "ARES", &m.ares) &&
                        ParseInt(p, "AMIN", &m.amin) && ParseInt(p, "AMAX", &m.amax) &&
                        ParseInt(p, "AFRT", &m.afrt) && ParseInt(p, "SCAN", &m.scan_rpm);
  if (!complete || m.ares <= 0 || m.scan_rpm <= 0 || m.amin > m.amax || m.dmin_mm >= m.dmax_mm) {
    Count("scip_decode", "PP reply incomplete or inconsistent");
    RequestReopen("PP reply incomplete or inconsistent");
    return false;
  }
  m.modl = modl->second;
  m.name = m.modl.find("UTM-30LX") != std::string::npos   ? "UTM-30LX"
           : m.modl.find("URG-04LX") != std::string::npos ? "URG-04LX"
                                                          : m.modl;
  if (config_.profile != "auto" && m.name != config_.profile) {
    RequestReopen("sensor is " + m.modl + ", profile expects " + config_.profile);
    return false;
  }
  first_step_ = config_.start_step < 0 ? m.amin : config_.start_step;
  last_step_ = config_.end_step < 0 ? m.amax : config_.end_step;
  if (first_step_ < m.amin || last_step_ > m.amax || first_step_ > last_step_) {
    RequestReopen("steps " + std::to_string(first_step_) + ".." + std::to_string(last_step_) +
                  " outside AMIN..AMAX = " + std::to_string(m.amin) + ".." +
                  std::to_string(m.amax));
    return false;
  }
  model_ = m;
  return true;
}

void HokuyoDriver::HandleScan(const scip::Reply& reply, int64_t now_utime) {
  if (reply.status != "99") {
    if (reply.status == "00") return;  // a repeated acknowledgement
    Count("scip_status", "stream: " + scip::DescribeStatus(reply.command(), reply.status));
    RequestReopen("stream error " + scip::DescribeStatus(reply.command(), reply.status));
    return;
  }
  const std::optional<scip::ScanData> data = scip::DecodeScan(reply);
  if (!data || data->timestamp_ms >= scip::kTimestampModulus) {
    Count("scip_decode", "malformed scan");
    return;
  }
  last_scan_utime_ = now_utime;
  const int64_t sensor_ms = unwrapper_.Unwrap(data->timestamp_ms);
  clock_.AddStreamSample(sensor_ms, now_utime);
  HokuyoScan scan;
  scan.sensor_timestamp_ms = data->timestamp_ms;
  scan.sensor_time_ms = sensor_ms;
  scan.receive_utime = now_utime;
  // The sensor stamps the first step (see emulator.h): that is the scan's stamp.
  scan.utime = clock_.HostUtime(sensor_ms);
  scan.angle_min_rad = static_cast<float>(model_.StepAngleRad(first_step_));
  scan.angle_step_rad = static_cast<float>(2.0 * M_PI / model_.ares);
  scan.time_step_s = static_cast<float>(model_.scan_period_s() / model_.ares);
  scan.range_min_m = static_cast<float>(model_.dmin_mm * 1e-3);
  scan.range_max_m = static_cast<float>(model_.dmax_mm * 1e-3);
  scan.ranges_m.reserve(data->ranges_mm.size());
  for (const uint32_t v : data->ranges_mm) {
    // Error codes below DMIN: docs/protocols.md §1.6 (no object -> 0, others -> NaN).
    switch (ClassifyRange(model_.name, model_.dmin_mm, model_.dmax_mm, v)) {
      case RangeClass::kReturn:
        scan.ranges_m.push_back(static_cast<float>(v * 1e-3));
        break;
      case RangeClass::kNoReturn:
        scan.ranges_m.push_back(0.0f);
        break;
      case RangeClass::kInvalid:
        scan.ranges_m.push_back(std::numeric_limits<float>::quiet_NaN());
        break;
    }
  }
  for (const uint32_t v : data->intensities) scan.intensities.push_back(static_cast<float>(v));
  ++scans_decoded_;
  scans_.push_back(std::move(scan));
}

}  // namespace kestrel

#include "drivers/xtion/xtion_node.h"

#include <algorithm>
#include <chrono>
#include <thread>

#include "common/identity.h"
#include "kestrel/heartbeat_t.hpp"
#include "lcmtypes/message_codecs.h"

namespace kestrel {

depth_image_t MakeDepthImage(const DepthFrame& frame, const PinholeIntrinsics& k, int64_t utime,
                             int64_t seq, int64_t epoch, const XtionConfig& config) {
  depth_image_t msg;
  msg.utime = utime;
  msg.seq = seq;
  msg.epoch = epoch;
  msg.sensor_name = config.sensor_name;
  msg.width = frame.width;
  msg.height = frame.height;
  msg.fx_px = k.fx_px;
  msg.fy_px = k.fy_px;
  msg.cx_px = k.cx_px;
  msg.cy_px = k.cy_px;
  msg.depth_scale_m = frame.hundred_um ? 1e-4 : 1e-3;
  msg.range_min_m = config.range_min_m;
  msg.range_max_m = config.range_max_m;
  EncodeDepthPixels(frame.counts,
                    config.encoding == "zlib" ? depth_image_t::ENCODING_ZLIB_U16
                                              : depth_image_t::ENCODING_RAW_U16,
                    config.zlib_level, &msg);
  return msg;
}

XtionNode::XtionNode(lcm::LCM& lcm, const XtionConfig& config, const Clock& clock)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      selector_(ParseDeviceSelector(config.device)),
      heartbeat_(lcm, clock, "kestrel-xtion", config.heartbeat_channel),
      drops_(clock),
      offset_(config.offset_window, SecondsToUtime(config.offset_reset_s)),
      epoch_(NewPublisherEpoch()),
      backoff_s_(config.reopen_initial_s) {
  config_.Validate();
  heartbeat_.SetState(heartbeat_t::STATE_STARTING);
}

void XtionNode::TryOpen(int64_t now_utime) {
  if (opened_once_ || stats_.reopen_failures > 0) ++stats_.reopen_attempts;
  std::string error;
  const std::vector<DeviceListing> devices =
      camera_.ListDevices(selector_.kind == DeviceSelector::Kind::kSerial);
  const std::optional<size_t> index = SelectDevice(selector_, devices);
  bool ok = false;
  if (!index) {
    error = "no device matches '" + config_.device + "' (" + std::to_string(devices.size()) +
            " listed)";
  } else {
    DepthMode mode;
    mode.width = config_.width;
    mode.height = config_.height;
    mode.fps = config_.fps;
    mode.hundred_um = config_.pixel_format == "depth_100_um";
    ok = camera_.Open(devices[*index].uri, mode, &error);
  }
  if (!ok) {
    ++stats_.reopen_failures;
    next_open_utime_ = now_utime + SecondsToUtime(backoff_s_);
    backoff_s_ = std::min(2.0 * backoff_s_, config_.reopen_max_s);
    heartbeat_.SetState(heartbeat_t::STATE_DEGRADED);
    heartbeat_.SetLastError(error);
    Log(LogLevel::kWarning, error);
    return;
  }
  try {
    intrinsics_ =
        IntrinsicsFromFov(config_.width, config_.height, camera_.hfov_rad(), camera_.vfov_rad());
  } catch (const std::invalid_argument& e) {
    // A device without a usable field of view cannot give intrinsics: treat as failed open.
    camera_.Close();
    ++stats_.reopen_failures;
    next_open_utime_ = now_utime + SecondsToUtime(backoff_s_);
    heartbeat_.SetLastError(std::string("bad field of view: ") + e.what());
    return;
  }
  Log(LogLevel::kInfo, "streaming " + camera_.uri() + " " + std::to_string(config_.width) + "x" +
                           std::to_string(config_.height) + "@" + std::to_string(config_.fps) +
                           " " + config_.pixel_format);
  opened_once_ = true;
  backoff_s_ = config_.reopen_initial_s;
  offset_.Reset();  // the device clock may have restarted
  last_frame_index_ = -1;
  last_frame_utime_ = now_utime;
  heartbeat_.SetState(heartbeat_t::STATE_OK);
}

void XtionNode::HandleLoss(int64_t now_utime, const std::string& reason, bool stall) {
  Log(LogLevel::kWarning, "device " + camera_.uri() + " lost: " + reason);
  camera_.Close();
  ++stats_.device_losses;
  if (stall) ++stats_.stalls;
  backoff_s_ = config_.reopen_initial_s;
  next_open_utime_ = now_utime + SecondsToUtime(backoff_s_);
  heartbeat_.SetState(heartbeat_t::STATE_DEGRADED);
  heartbeat_.SetLastError("device lost: " + reason);
}

void XtionNode::Poll(int timeout_ms) {
  int64_t now = clock_.NowUtime();
  if (!camera_.is_open()) {
    if (now < next_open_utime_) {
      const int64_t wait_ms = std::min<int64_t>(timeout_ms, (next_open_utime_ - now) / 1000 + 1);
      if (!clock_.is_simulated() && wait_ms > 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
      }
      return;
    }
    TryOpen(now);
    return;
  }
  if (camera_.lost()) {
    HandleLoss(now, "OpenNI2 reported the device disconnected", false);
    return;
  }
  const OpenNiDepthCamera::ReadStatus status = camera_.Read(timeout_ms, &frame_);
  now = clock_.NowUtime();
  if (status == OpenNiDepthCamera::ReadStatus::kTimeout) {
    if (camera_.lost()) {
      HandleLoss(now, "OpenNI2 reported the device disconnected", false);
    } else if (now - last_frame_utime_ > SecondsToUtime(config_.frame_timeout_s)) {
      HandleLoss(now, "no frame for " + std::to_string(config_.frame_timeout_s) + " s", true);
    }
    return;
  }
  if (status == OpenNiDepthCamera::ReadStatus::kError) {
    HandleLoss(now, "read failed", false);
    return;
  }
  last_frame_utime_ = now;
  if (last_frame_index_ >= 0 && frame_.frame_index > last_frame_index_ + 1) {
    const int64_t gap = frame_.frame_index - last_frame_index_ - 1;
    stats_.frames_dropped += gap;
    drops_.Count("frame gap", std::to_string(gap) + " frame(s) skipped before index " +
                                  std::to_string(frame_.frame_index));
  }
  last_frame_index_ = frame_.frame_index;
  const bool hundred_um = config_.pixel_format == "depth_100_um";
  if (frame_.width != config_.width || frame_.height != config_.height ||
      frame_.hundred_um != hundred_um) {
    ++stats_.frames_dropped;
    drops_.Count("wrong mode", "frame " + std::to_string(frame_.width) + "x" +
                                   std::to_string(frame_.height) + " differs from the config");
    return;
  }
  // Device time to host time: host arrival minus device stamp, median over the window.
  if (offset_.AddSample(frame_.device_us, now)) ++stats_.offset_resets;
  const int64_t utime = offset_.ToHostUtime(frame_.device_us);
  try {
    const depth_image_t msg = MakeDepthImage(frame_, intrinsics_, utime, seq_++, epoch_, config_);
    lcm_.publish(config_.channel, &msg);
    ++stats_.frames_published;
  } catch (const std::runtime_error& e) {
    ++stats_.frames_dropped;
    drops_.Count("encode", e.what());
  }
}

void XtionNode::PublishHeartbeat() {
  const int64_t now = clock_.NowUtime();
  const double dt_s = UtimeToSeconds(now - last_heartbeat_utime_);
  if (last_heartbeat_utime_ > 0 && dt_s > 0.0) {
    heartbeat_.SetValue(
        "rate_hz",
        static_cast<double>(stats_.frames_published - published_at_last_heartbeat_) / dt_s);
  }
  last_heartbeat_utime_ = now;
  published_at_last_heartbeat_ = stats_.frames_published;
  heartbeat_.SetValue("frames_published", static_cast<double>(stats_.frames_published));
  heartbeat_.SetValue("frames_dropped", static_cast<double>(stats_.frames_dropped));
  heartbeat_.SetValue("device_losses", static_cast<double>(stats_.device_losses));
  heartbeat_.SetValue("stalls", static_cast<double>(stats_.stalls));
  heartbeat_.SetValue("reopen_attempts", static_cast<double>(stats_.reopen_attempts));
  heartbeat_.SetValue("reopen_failures", static_cast<double>(stats_.reopen_failures));
  heartbeat_.SetValue("offset_resets", static_cast<double>(stats_.offset_resets));
  heartbeat_.SetValue("clock_offset_us", static_cast<double>(offset_.offset_us()));
  heartbeat_.SetValue("streaming", camera_.is_open() ? 1.0 : 0.0);
  heartbeat_.Publish();
}

}  // namespace kestrel

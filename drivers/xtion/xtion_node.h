#pragma once
/// @file
/// kestrel-xtion's node: opens the configured OpenNI2 depth stream, converts each frame's device
/// time stamp to host time with a median-smoothed offset, publishes kestrel::depth_image_t on
/// DEPTH_XTION (raw or zlib), recovers from device loss (stop, wait, reopen with back-off,
/// restore the mode) and reports counters in its heartbeat (HEARTBEAT_XTION).
///
/// Single-threaded: the owner calls Poll() in its loop and PublishHeartbeat() from a timer.

#include <cstdint>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/heartbeat.h"
#include "common/log.h"
#include "drivers/xtion/openni_camera.h"
#include "drivers/xtion/xtion_config.h"
#include "drivers/xtion/xtion_pure.h"
#include "kestrel/depth_image_t.hpp"

namespace kestrel {

/// Builds the message for one frame: host time `utime`, sequence `seq` and publisher `epoch`
/// (common/identity.h), intrinsics `k`, payload encoded per `config` (depth_scale_m 1e-3 for
/// DEPTH_1_MM, 1e-4 for DEPTH_100_UM). @throws std::runtime_error if encoding fails.
[[nodiscard]] depth_image_t MakeDepthImage(const DepthFrame& frame, const PinholeIntrinsics& k,
                                           int64_t utime, int64_t seq, int64_t epoch,
                                           const XtionConfig& config);

/// What the node has done so far (also published in the heartbeat under these names).
struct XtionStats {
  int64_t frames_published{0};  ///< depth_image_t messages sent
  int64_t frames_dropped{0};    ///< device frame-index gaps, bad frames, wrong modes
  int64_t device_losses{0};     ///< losses reported by OpenNI2 or read errors while streaming
  int64_t stalls{0};            ///< streams silent for frame_timeout_s (treated as a loss)
  int64_t reopen_attempts{0};   ///< open attempts after the first
  int64_t reopen_failures{0};   ///< failed open attempts (first included)
  int64_t offset_resets{0};     ///< restarts of the clock-offset window
};

class XtionNode {
 public:
  /// Initializes OpenNI2 (the first open happens in the first Poll).
  /// @throws std::runtime_error if OpenNI2 cannot be initialized.
  XtionNode(lcm::LCM& lcm, const XtionConfig& config, const Clock& clock);
  XtionNode(const XtionNode&) = delete;
  XtionNode& operator=(const XtionNode&) = delete;

  /// One step: opens the device when due; while streaming, waits at most timeout_ms for one
  /// frame and publishes it, or notices a loss / stall and closes the device.
  void Poll(int timeout_ms);
  /// Publishes the heartbeat with the counters of stats() and the current offset.
  void PublishHeartbeat();

  [[nodiscard]] const XtionStats& stats() const { return stats_; }
  [[nodiscard]] bool streaming() const { return camera_.is_open(); }
  /// Current smoothed host-minus-device offset, us (0 before the first frame).
  /// The publisher epoch stamped on every depth image (common/identity.h).
  [[nodiscard]] int64_t epoch() const { return epoch_; }
  [[nodiscard]] int64_t clock_offset_us() const { return offset_.offset_us(); }
  /// Intrinsics of the open stream (from its field of view).
  [[nodiscard]] const PinholeIntrinsics& intrinsics() const { return intrinsics_; }
  /// The device list as OpenNI2 reports it (serials read), for --list.
  [[nodiscard]] std::vector<DeviceListing> ListDevices() { return camera_.ListDevices(true); }

 private:
  void TryOpen(int64_t now_utime);
  void HandleLoss(int64_t now_utime, const std::string& reason, bool stall);

  lcm::LCM& lcm_;
  XtionConfig config_;
  const Clock& clock_;
  DeviceSelector selector_;
  OpenNiDepthCamera camera_;
  Heartbeat heartbeat_;
  DropCounter drops_;
  ClockOffsetFilter offset_;
  PinholeIntrinsics intrinsics_;
  XtionStats stats_;
  DepthFrame frame_;
  int64_t epoch_;
  int64_t seq_{0};
  int64_t last_frame_index_{-1};
  int64_t last_frame_utime_{0};
  int64_t next_open_utime_{0};
  double backoff_s_{0.0};
  bool opened_once_{false};
  int64_t last_heartbeat_utime_{0};
  int64_t published_at_last_heartbeat_{0};
};

}  // namespace kestrel

#pragma once
/// @file
/// The plugin's LCM frame source: subscribes to kestrel::depth_image_t (e.g. the simulator's
/// SIM_DEPTH_XTION) on its own LCM instance and thread, decodes each message through Kestrel's
/// guarded decoder, and keeps the latest frame for the streams, which raise one OpenNI2 frame
/// per message received. Malformed messages and bad payloads are counted and dropped.

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace kestrel::oni_plugin {

/// One received depth image, payload decoded.
struct ReceivedDepth {
  int64_t number{0};             ///< 1, 2, ... in order of arrival (0: none yet)
  int64_t utime{0};              ///< the message's utime (the simulator's clock), us
  int width{0};                  ///< pixels
  int height{0};                 ///< pixels
  double depth_scale_m{0.0};     ///< metres per count
  std::vector<uint16_t> counts;  ///< row-major, 0 = no return
};

/// Converts counts from one scale to another: round(c * from / to); counts that do not fit
/// 16 bits become 0 (no return); 0 stays 0.
[[nodiscard]] std::vector<uint16_t> RescaleCounts(const std::vector<uint16_t>& counts,
                                                  double from_scale_m, double to_scale_m);

class LcmFrameSource {
 public:
  /// Starts the receive thread on `url` (LCM provider URL) subscribed to `channel`.
  /// @throws std::runtime_error if LCM cannot be opened.
  LcmFrameSource(const std::string& url, const std::string& channel, bool verbose);
  ~LcmFrameSource();
  LcmFrameSource(const LcmFrameSource&) = delete;
  LcmFrameSource& operator=(const LcmFrameSource&) = delete;

  /// Waits at most timeout_ms for a frame with number > after; copies it and returns true.
  bool WaitNewer(int64_t after, int timeout_ms, ReceivedDepth* out);
  /// Messages dropped (malformed, bad payload).
  [[nodiscard]] int64_t dropped() const;

 private:
  void Run(const std::string& url, const std::string& channel);

  bool verbose_;
  mutable std::mutex mutex_;
  std::condition_variable arrived_;
  ReceivedDepth latest_;
  int64_t dropped_{0};
  bool stopping_{false};
  bool started_{false};
  std::string start_error_;
  std::thread thread_;
};

}  // namespace kestrel::oni_plugin

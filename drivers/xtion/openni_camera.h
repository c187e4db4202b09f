#pragma once
/// @file
/// A thin layer over the OpenNI2 C++ API (openni::OpenNI, Device, VideoStream) for one depth
/// stream: list devices, open one with a mode, read frames with a time-out, notice device loss
/// (OpenNI2's disconnected / state-changed events), close. No policy: kestrel-xtion's XtionNode
/// decides when to reopen.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "drivers/xtion/xtion_pure.h"

namespace kestrel {

/// A depth mode as requested from OpenNI2.
struct DepthMode {
  int width{640};          ///< pixels
  int height{480};         ///< pixels
  int fps{30};             ///< Hz
  bool hundred_um{false};  ///< true: ONI_PIXEL_FORMAT_DEPTH_100_UM, false: DEPTH_1_MM
};

/// One frame as read from OpenNI2.
struct DepthFrame {
  int64_t device_us{0};          ///< device time stamp, us (the device's clock)
  int64_t frame_index{0};        ///< the device's frame counter
  int width{0};                  ///< pixels
  int height{0};                 ///< pixels
  bool hundred_um{false};        ///< pixel format of the counts
  std::vector<uint16_t> counts;  ///< row-major depth counts, 0 = no return
};

/// OpenNI2 initialized for the process (openni::OpenNI::initialize/shutdown), and one depth
/// stream of one device at a time.
class OpenNiDepthCamera {
 public:
  /// Initializes OpenNI2. @throws std::runtime_error with OpenNI2's extended error on failure.
  OpenNiDepthCamera();
  ~OpenNiDepthCamera();
  OpenNiDepthCamera(const OpenNiDepthCamera&) = delete;
  OpenNiDepthCamera& operator=(const OpenNiDepthCamera&) = delete;

  /// The devices OpenNI2 currently knows. With `read_serials`, each device not currently open
  /// by this object is opened briefly to read ONI_DEVICE_PROPERTY_SERIAL_NUMBER.
  [[nodiscard]] std::vector<DeviceListing> ListDevices(bool read_serials);

  /// Opens `uri`, sets `mode` on its depth stream, turns mirroring off (if the device supports the
  /// property) and starts it. Closes any open device first.
  /// Returns false with `*error` set on failure (device gone, mode refused ...).
  bool Open(const std::string& uri, const DepthMode& mode, std::string* error);
  /// Stops and destroys the stream and closes the device (no-op if nothing is open).
  void Close();
  [[nodiscard]] bool is_open() const;
  [[nodiscard]] const std::string& uri() const { return uri_; }
  /// Horizontal / vertical field of view of the open stream, radians (from OpenNI2).
  [[nodiscard]] double hfov_rad() const { return hfov_rad_; }
  [[nodiscard]] double vfov_rad() const { return vfov_rad_; }

  enum class ReadStatus { kFrame, kTimeout, kError };
  /// Waits at most timeout_ms for a frame of the open stream and copies it into `*frame`.
  ReadStatus Read(int timeout_ms, DepthFrame* frame);
  /// True once OpenNI2 reported the open device disconnected or in an error state.
  [[nodiscard]] bool lost() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string uri_;
  double hfov_rad_{0.0};
  double vfov_rad_{0.0};
};

}  // namespace kestrel

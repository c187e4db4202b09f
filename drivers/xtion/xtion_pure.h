#pragma once
/// @file
/// The pure pieces of kestrel-xtion (no OpenNI, no LCM): pinhole intrinsics from the stream's
/// field of view, device selection the way openni2_camera does it, the smoothed device-to-host
/// clock offset, and the depth payload encoding of kestrel::depth_image_t.
///
/// Intrinsics convention (stated once, shared with the OpenNI2 test plugin): optical frame S
/// (z forward, x right, y down), pixel centres at integer coordinates, the optical axis through
/// the image centre: fx = (w/2) / tan(hfov/2), fy = (h/2) / tan(vfov/2), cx = (w-1)/2,
/// cy = (h-1)/2. So the left edge of pixel 0 (u = -0.5) is at angle -hfov/2.

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

namespace kestrel {

/// Pinhole intrinsics in pixels.
struct PinholeIntrinsics {
  double fx_px{0.0};  ///< focal length along x (columns), pixels
  double fy_px{0.0};  ///< focal length along y (rows), pixels
  double cx_px{0.0};  ///< principal point column, pixels
  double cy_px{0.0};  ///< principal point row, pixels
};

/// Intrinsics of a width x height image with the given full fields of view (radians), per the
/// convention in the file comment.
/// @throws std::invalid_argument unless width, height > 0 and both fovs are in (0, pi).
[[nodiscard]] PinholeIntrinsics IntrinsicsFromFov(int width, int height, double hfov_rad,
                                                  double vfov_rad);

/// Which device to open, as openni2_camera's `device_id`: empty = the first device listed,
/// "#N" = the N-th device (1-based), "B@A" = the device on USB bus B at address A (its URI
/// "vvvv/pppp@B/A"), anything else = a serial number (ONI_DEVICE_PROPERTY_SERIAL_NUMBER).
struct DeviceSelector {
  enum class Kind { kFirst, kIndex, kBusAddress, kSerial };
  Kind kind{Kind::kFirst};
  int index{0};        ///< kIndex: 1-based position in the device list
  int bus{0};          ///< kBusAddress: USB bus number
  int address{0};      ///< kBusAddress: USB device address
  std::string serial;  ///< kSerial: serial number, compared exactly
};

/// Parses a device_id. @throws std::invalid_argument on "#0", "#x", "1@", "@2", "a@b" ...
[[nodiscard]] DeviceSelector ParseDeviceSelector(const std::string& device_id);

/// A device as listed by OpenNI2.
struct DeviceListing {
  std::string uri;     ///< e.g. "1d27/0600@1/10"
  std::string serial;  ///< "" if not read
};

/// The USB bus and address in a PS1080-style URI "vvvv/pppp@B/A", if it has that form.
[[nodiscard]] std::optional<std::pair<int, int>> UsbBusAddressOfUri(const std::string& uri);

/// The position in `devices` of the device `selector` names, or nullopt if none matches.
[[nodiscard]] std::optional<size_t> SelectDevice(const DeviceSelector& selector,
                                                 const std::vector<DeviceListing>& devices);

/// Smoothed offset between a device clock and the host clock: the median of the last `window`
/// samples (host arrival time - device time stamp), both in microseconds. Arrival latency biases
/// each sample by the transport delay; the median rejects the occasional late frame. A sample
/// that differs from the current median by more than `reset_us` (the device clock restarted or
/// jumped) restarts the window.
class ClockOffsetFilter {
 public:
  /// @throws std::invalid_argument unless window >= 1 and reset_us > 0.
  ClockOffsetFilter(int window, int64_t reset_us);

  /// Adds one sample; returns true if it restarted the window.
  bool AddSample(int64_t device_us, int64_t host_us);
  /// Forgets every sample (call when the device is reopened).
  void Reset() { samples_.clear(); }
  /// Median of the window (the lower of the two middle samples for an even count); 0 if empty.
  [[nodiscard]] int64_t offset_us() const;
  /// device_us + offset_us(). Precondition: at least one sample.
  [[nodiscard]] int64_t ToHostUtime(int64_t device_us) const;
  [[nodiscard]] int size() const { return static_cast<int>(samples_.size()); }
  [[nodiscard]] int64_t resets() const { return resets_; }

 private:
  int window_;
  int64_t reset_us_;
  std::deque<int64_t> samples_;  // oldest first
  int64_t resets_{0};
};

}  // namespace kestrel

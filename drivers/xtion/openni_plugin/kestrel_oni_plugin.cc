/// @file
/// Kestrel's OpenNI2 driver plugin: announces PS1080-like depth cameras (USB 1d27:0600) and
/// serves depth frames from an analytic scene or a folder of raw frames, so that kestrel-xtion
/// runs unchanged against the real OpenNI2 library in tests and simulated flights. Configured by
/// environment variables (plugin_config.h); the lcm:URL source serves the simulator's frames. Built
/// as lib<name>.so.0, the name Debian's OpenNI2 loads from its drivers repository.
///
/// Threads: OpenNI2 calls in from the client's threads; each started stream has one frame thread
/// that paces frames on an absolute grid and raises them; one event thread delivers device loss
/// and return (never from the frame thread, since OpenNI2 may stop streams inside the callbacks).

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <Driver/OniDriverAPI.h>

#include "drivers/xtion/openni_plugin/lcm_frame_source.h"
#include "drivers/xtion/openni_plugin/plugin_config.h"
#include "drivers/xtion/openni_plugin/synthetic_scene.h"

// ONI_EXPORT_DRIVER allocates with OpenNI's internal XnLib macros, which the installed headers
// do not provide.
#define XN_NEW(type, arg) new type(arg)
#define XN_DELETE(p) delete (p)

namespace kestrel::oni_plugin {
namespace {

int64_t HostNowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

double DepthScaleM(OniPixelFormat format) {
  return format == ONI_PIXEL_FORMAT_DEPTH_100_UM ? 1e-4 : 1e-3;
}

// The supported depth modes: QVGA@30, QVGA@60, VGA@30, each in 1 mm and 100 um.
std::vector<OniVideoMode> SupportedModes() {
  std::vector<OniVideoMode> modes;
  for (const OniPixelFormat format : {ONI_PIXEL_FORMAT_DEPTH_1_MM, ONI_PIXEL_FORMAT_DEPTH_100_UM}) {
    modes.push_back({format, 320, 240, 30});
    modes.push_back({format, 320, 240, 60});
    modes.push_back({format, 640, 480, 30});
  }
  return modes;
}

bool SameMode(const OniVideoMode& a, const OniVideoMode& b) {
  return a.pixelFormat == b.pixelFormat && a.resolutionX == b.resolutionX &&
         a.resolutionY == b.resolutionY && a.fps == b.fps;
}

template <typename T>
OniStatus CopyOut(const T& value, void* data, int* size) {
  if (data == nullptr || size == nullptr || *size < static_cast<int>(sizeof(T))) {
    return ONI_STATUS_BAD_PARAMETER;
  }
  std::memcpy(data, &value, sizeof(T));
  *size = static_cast<int>(sizeof(T));
  return ONI_STATUS_OK;
}

class KestrelDriver;

class KestrelDepthStream final : public oni::driver::StreamBase {
 public:
  KestrelDepthStream(KestrelDriver* driver, int device_index);
  ~KestrelDepthStream() override { stop(); }

  OniStatus start() override;
  void stop() override;
  OniStatus setProperty(int property_id, const void* data, int data_size) override;
  OniStatus getProperty(int property_id, void* data, int* data_size) override;
  OniBool isPropertySupported(int property_id) override;
  int getRequiredFrameSize() override {
    return mode_.resolutionX * mode_.resolutionY * static_cast<int>(sizeof(OniDepthPixel));
  }

 private:
  void Run();

  KestrelDriver* driver_;
  int device_index_;
  OniVideoMode mode_{ONI_PIXEL_FORMAT_DEPTH_1_MM, 320, 240, 30};
  bool mirroring_{false};
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool running_{false};
};

class KestrelDevice final : public oni::driver::DeviceBase {
 public:
  KestrelDevice(KestrelDriver* driver, int device_index)
      : driver_(driver), device_index_(device_index), modes_(SupportedModes()) {
    sensor_.sensorType = ONI_SENSOR_DEPTH;
    sensor_.numSupportedVideoModes = static_cast<int>(modes_.size());
    sensor_.pSupportedVideoModes = modes_.data();
  }

  OniStatus getSensorInfoList(OniSensorInfo** sensors, int* num_sensors) override {
    *sensors = &sensor_;
    *num_sensors = 1;
    return ONI_STATUS_OK;
  }
  oni::driver::StreamBase* createStream(OniSensorType type) override {
    if (type != ONI_SENSOR_DEPTH) return nullptr;
    return new KestrelDepthStream(driver_, device_index_);
  }
  void destroyStream(oni::driver::StreamBase* stream) override { delete stream; }

  OniStatus getProperty(int property_id, void* data, int* data_size) override {
    switch (property_id) {
      case ONI_DEVICE_PROPERTY_SERIAL_NUMBER:
      case ONI_DEVICE_PROPERTY_FIRMWARE_VERSION: {
        const std::string text = property_id == ONI_DEVICE_PROPERTY_SERIAL_NUMBER
                                     ? DeviceSerial(device_index_)
                                     : std::string("5.8.22-kestrel");
        if (data == nullptr || data_size == nullptr ||
            *data_size < static_cast<int>(text.size()) + 1) {
          return ONI_STATUS_BAD_PARAMETER;
        }
        std::memcpy(data, text.c_str(), text.size() + 1);
        *data_size = static_cast<int>(text.size()) + 1;
        return ONI_STATUS_OK;
      }
      case ONI_DEVICE_PROPERTY_HARDWARE_VERSION:
        return CopyOut(int{6}, data, data_size);
      case ONI_DEVICE_PROPERTY_DRIVER_VERSION:
        return CopyOut(OniVersion{5, 8, 22, 0}, data, data_size);
      default:
        return ONI_STATUS_NOT_SUPPORTED;
    }
  }
  OniBool isPropertySupported(int property_id) override {
    return property_id == ONI_DEVICE_PROPERTY_SERIAL_NUMBER ||
           property_id == ONI_DEVICE_PROPERTY_FIRMWARE_VERSION ||
           property_id == ONI_DEVICE_PROPERTY_HARDWARE_VERSION ||
           property_id == ONI_DEVICE_PROPERTY_DRIVER_VERSION;
  }

 private:
  KestrelDriver* driver_;
  int device_index_;
  std::vector<OniVideoMode> modes_;
  OniSensorInfo sensor_{};
};

class KestrelDriver final : public oni::driver::DriverBase {
 public:
  explicit KestrelDriver(OniDriverServices* services) : DriverBase(services) {}
  ~KestrelDriver() override { shutdown(); }

  OniStatus initialize(oni::driver::DeviceConnectedCallback connected,
                       oni::driver::DeviceDisconnectedCallback disconnected,
                       oni::driver::DeviceStateChangedCallback state_changed,
                       void* cookie) override {
    const OniStatus status = DriverBase::initialize(connected, disconnected, state_changed, cookie);
    if (status != ONI_STATUS_OK) return status;
    try {
      config_ = ReadPluginConfig([](const char* name) { return std::getenv(name); });
      if (config_.source == "files") files_ = std::make_unique<RawFrameFolder>(config_.files_dir);
      if (config_.source == "lcm") {
        lcm_ =
            std::make_unique<LcmFrameSource>(config_.lcm_url, config_.lcm_channel, config_.verbose);
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "kestrel-oni-plugin: %s\n", e.what());
      return ONI_STATUS_ERROR;
    }
    // Device clock: by default it reads 1 s at load; for the LCM source it is the sender's clock.
    clock_offset_us_ = config_.clock_offset_given ? config_.clock_offset_us
                       : lcm_ != nullptr          ? 0
                                                  : 1000000 - HostNowUs();
    drift_origin_us_ = HostNowUs();
    losses_left_ = config_.loss_count;
    stall_pending_ = config_.stall_after_frames > 0;
    infos_.resize(static_cast<size_t>(config_.num_devices));
    lost_ = std::make_unique<std::atomic<bool>[]>(infos_.size());
    for (int i = 0; i < config_.num_devices; ++i) {
      OniDeviceInfo& info = infos_[static_cast<size_t>(i)];
      info = OniDeviceInfo{};
      std::snprintf(info.uri, sizeof(info.uri), "%s", DeviceUri(i).c_str());
      std::snprintf(info.vendor, sizeof(info.vendor), "%s", "PrimeSense");
      std::snprintf(info.name, sizeof(info.name), "%s", "PS1080");
      info.usbVendorId = 0x1d27;
      info.usbProductId = 0x0600;
      lost_[static_cast<size_t>(i)] = false;
    }
    events_ = std::thread([this] { RunEvents(); });
    for (const auto& info : infos_) deviceConnected(&info);
    Verbose("initialized: " + std::to_string(infos_.size()) + " device(s), source " +
            config_.source);
    return ONI_STATUS_OK;
  }

  OniStatus tryDevice(const char* uri) override {
    const int index = IndexOf(uri);
    if (index < 0 || lost(index)) return ONI_STATUS_ERROR;
    deviceConnected(&infos_[static_cast<size_t>(index)]);
    return ONI_STATUS_OK;
  }

  oni::driver::DeviceBase* deviceOpen(const char* uri, const char* /*mode*/) override {
    const int index = IndexOf(uri);
    if (index < 0 || lost(index)) return nullptr;
    Verbose(std::string("open ") + uri);
    return new KestrelDevice(this, index);
  }
  void deviceClose(oni::driver::DeviceBase* device) override { delete device; }

  void shutdown() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) return;
      stopping_ = true;
    }
    wake_.notify_all();
    if (events_.joinable()) events_.join();
    lcm_.reset();
  }

  // --- for streams ---
  [[nodiscard]] bool lost(int index) const { return lost_[static_cast<size_t>(index)].load(); }
  /// The device clock: host time + offset, running fast by drift_ppm since the plugin loaded.
  [[nodiscard]] int64_t DeviceNowUs() const {
    const int64_t host_us = HostNowUs();
    const double drift_us =
        config_.clock_drift_ppm * 1e-6 * static_cast<double>(host_us - drift_origin_us_);
    return host_us + clock_offset_us_.load() + static_cast<int64_t>(std::llround(drift_us));
  }
  [[nodiscard]] int64_t clock_offset_us() const { return clock_offset_us_.load(); }
  /// True while the configured stall keeps every stream silent.
  [[nodiscard]] bool stalled() const {
    return std::chrono::steady_clock::now().time_since_epoch().count() < stall_until_.load();
  }
  [[nodiscard]] LcmFrameSource* lcm() const { return lcm_.get(); }
  [[nodiscard]] const PluginConfig& config() const { return config_; }
  [[nodiscard]] const RawFrameFolder* files() const { return files_.get(); }

  /// Counts a raised frame of device `index`; triggers the configured loss.
  void CountFrame(int index) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++frames_since_return_;
    ++frames_total_;
    if (stall_pending_ && frames_total_ >= config_.stall_after_frames) {
      stall_pending_ = false;
      stall_until_ =
          (std::chrono::steady_clock::now() + std::chrono::milliseconds(config_.stall_duration_ms))
              .time_since_epoch()
              .count();
      Verbose("stall for " + std::to_string(config_.stall_duration_ms) + " ms");
    }
    if (config_.loss_after_frames > 0 && losses_left_ > 0 &&
        frames_since_return_ >= config_.loss_after_frames && !lost(index)) {
      --losses_left_;
      lost_[static_cast<size_t>(index)] = true;
      pending_.push_back(index);
      wake_.notify_all();
    }
  }

  void Verbose(const std::string& text) const {
    if (config_.verbose) std::fprintf(stderr, "kestrel-oni-plugin: %s\n", text.c_str());
  }

 private:
  int IndexOf(const char* uri) const {
    if (uri == nullptr) return -1;
    for (size_t i = 0; i < infos_.size(); ++i) {
      if (std::strcmp(uri, infos_[i].uri) == 0) return static_cast<int>(i);
    }
    return -1;
  }

  // Delivers losses: state ERROR and disconnection now, the return after loss_duration_ms.
  void RunEvents() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stopping_) {
      wake_.wait(lock, [this] { return stopping_ || !pending_.empty(); });
      if (stopping_) break;
      const int index = pending_.front();
      pending_.pop_front();
      const OniDeviceInfo& info = infos_[static_cast<size_t>(index)];
      lock.unlock();
      Verbose(std::string("device lost: ") + info.uri);
      deviceStateChanged(&info, ONI_DEVICE_STATE_ERROR);
      deviceDisconnected(&info);
      lock.lock();
      const auto back =
          std::chrono::steady_clock::now() + std::chrono::milliseconds(config_.loss_duration_ms);
      if (wake_.wait_until(lock, back, [this] { return stopping_; })) break;
      lost_[static_cast<size_t>(index)] = false;
      frames_since_return_ = 0;
      if (!config_.clock_offset_given && lcm_ == nullptr) {
        clock_offset_us_ = 1000000 - HostNowUs();  // the device clock restarts
      }
      lock.unlock();
      Verbose(std::string("device back: ") + info.uri);
      deviceConnected(&info);
      deviceStateChanged(&info, ONI_DEVICE_STATE_OK);
      lock.lock();
    }
  }

  PluginConfig config_;
  std::unique_ptr<RawFrameFolder> files_;
  std::unique_ptr<LcmFrameSource> lcm_;
  std::atomic<int64_t> clock_offset_us_{0};  // device minus host clock, us
  int64_t drift_origin_us_{0};               // host time at which the drift term is zero
  std::atomic<int64_t> stall_until_{0};      // steady_clock ticks; streams silent before
  bool stall_pending_{false};
  int64_t frames_total_{0};
  std::vector<OniDeviceInfo> infos_;
  std::unique_ptr<std::atomic<bool>[]> lost_;
  std::thread events_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<int> pending_;
  bool stopping_{false};
  int64_t frames_since_return_{0};
  int losses_left_{0};
};

KestrelDepthStream::KestrelDepthStream(KestrelDriver* driver, int device_index)
    : driver_(driver), device_index_(device_index), mirroring_(driver->config().mirror_default) {}

OniStatus KestrelDepthStream::start() {
  if (driver_->lost(device_index_)) return ONI_STATUS_ERROR;
  std::lock_guard<std::mutex> lock(mutex_);
  if (running_) return ONI_STATUS_OK;
  running_ = true;
  thread_ = std::thread([this] { Run(); });
  return ONI_STATUS_OK;
}

void KestrelDepthStream::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    running_ = false;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

OniStatus KestrelDepthStream::setProperty(int property_id, const void* data, int data_size) {
  if (data == nullptr) return ONI_STATUS_BAD_PARAMETER;
  if (property_id == ONI_STREAM_PROPERTY_VIDEO_MODE) {
    if (data_size != static_cast<int>(sizeof(OniVideoMode))) return ONI_STATUS_BAD_PARAMETER;
    OniVideoMode mode;
    std::memcpy(&mode, data, sizeof(mode));
    const auto modes = SupportedModes();
    if (std::none_of(modes.begin(), modes.end(),
                     [&](const OniVideoMode& m) { return SameMode(m, mode); })) {
      return ONI_STATUS_NOT_SUPPORTED;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (running_) return ONI_STATUS_OUT_OF_FLOW;  // the frame size would change under OpenNI
    mode_ = mode;
    return ONI_STATUS_OK;
  }
  if (property_id == ONI_STREAM_PROPERTY_MIRRORING) {
    if (data_size != static_cast<int>(sizeof(OniBool))) return ONI_STATUS_BAD_PARAMETER;
    OniBool on;
    std::memcpy(&on, data, sizeof(on));
    std::lock_guard<std::mutex> lock(mutex_);
    mirroring_ = on != 0;
    return ONI_STATUS_OK;
  }
  return ONI_STATUS_NOT_SUPPORTED;
}

OniStatus KestrelDepthStream::getProperty(int property_id, void* data, int* data_size) {
  std::lock_guard<std::mutex> lock(mutex_);
  const float max_value = 65535.0F;
  switch (property_id) {
    case ONI_STREAM_PROPERTY_VIDEO_MODE:
      return CopyOut(mode_, data, data_size);
    case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
      return CopyOut(static_cast<float>(kHorizontalFovRad), data, data_size);
    case ONI_STREAM_PROPERTY_VERTICAL_FOV:
      return CopyOut(static_cast<float>(kVerticalFovRad), data, data_size);
    case ONI_STREAM_PROPERTY_MAX_VALUE: {
      const double max_count = kMaxDepthM / DepthScaleM(mode_.pixelFormat);
      return CopyOut(static_cast<int>(std::min<double>(max_count, max_value)), data, data_size);
    }
    case ONI_STREAM_PROPERTY_MIN_VALUE:
      return CopyOut(int{0}, data, data_size);
    case ONI_STREAM_PROPERTY_STRIDE:
      return CopyOut(static_cast<int>(mode_.resolutionX * sizeof(OniDepthPixel)), data, data_size);
    case ONI_STREAM_PROPERTY_MIRRORING:
      return CopyOut(OniBool{mirroring_ ? TRUE : FALSE}, data, data_size);
    default:
      return ONI_STATUS_NOT_SUPPORTED;
  }
}

OniBool KestrelDepthStream::isPropertySupported(int property_id) {
  return property_id == ONI_STREAM_PROPERTY_VIDEO_MODE ||
         property_id == ONI_STREAM_PROPERTY_HORIZONTAL_FOV ||
         property_id == ONI_STREAM_PROPERTY_VERTICAL_FOV ||
         property_id == ONI_STREAM_PROPERTY_MAX_VALUE ||
         property_id == ONI_STREAM_PROPERTY_MIN_VALUE ||
         property_id == ONI_STREAM_PROPERTY_STRIDE || property_id == ONI_STREAM_PROPERTY_MIRRORING;
}

void KestrelDepthStream::Run() {
  OniVideoMode mode;
  bool mirror;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    mode = mode_;
    mirror = mirroring_;
  }
  const int w = mode.resolutionX;
  const int h = mode.resolutionY;
  const auto period = std::chrono::microseconds(1000000 / std::max(1, mode.fps));
  WallScene scene = driver_->config().wall;
  scene.distance_m += 0.25 * device_index_;
  std::vector<uint16_t> pixels;
  int64_t served = 0;  // frames served by this stream; the scene's frame index
  auto next = std::chrono::steady_clock::now();
  LcmFrameSource* const lcm = driver_->lcm();
  ReceivedDepth received;
  for (;;) {
    int64_t device_us = 0;
    if (lcm != nullptr) {
      // One frame per message, when it arrives; poll the stop flag between waits.
      const bool got = lcm->WaitNewer(received.number, 50, &received);
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!running_) return;
      }
      if (!got || driver_->lost(device_index_) || driver_->stalled()) continue;
      if (received.width != w || received.height != h) {
        driver_->Verbose("received " + std::to_string(received.width) + "x" +
                         std::to_string(received.height) + " for a " + std::to_string(w) + "x" +
                         std::to_string(h) + " stream: dropped");
        continue;
      }
      pixels =
          RescaleCounts(received.counts, received.depth_scale_m, DepthScaleM(mode.pixelFormat));
      device_us = received.utime + driver_->clock_offset_us();
    } else {
      next += period;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        if (wake_.wait_until(lock, next, [this] { return !running_; })) return;
      }
      if (driver_->lost(device_index_) || driver_->stalled()) continue;  // silent camera
      const int64_t skip = driver_->config().skip_every_frames;
      if (skip > 0 && (served + 1) % skip == 0) {
        ++served;  // the device consumed the index but the frame never arrives
        continue;
      }
      device_us = driver_->DeviceNowUs();
      if (driver_->files() != nullptr) {
        if (!driver_->files()->Fill(w, h, served, &pixels)) {
          driver_->Verbose("frame file size does not match " + std::to_string(w) + "x" +
                           std::to_string(h));
          ++served;
          continue;
        }
      } else {
        RenderWall(scene, w, h, DepthScaleM(mode.pixelFormat), served, &pixels);
      }
    }
    if (mirror) {
      for (int v = 0; v < h; ++v) {
        std::reverse(pixels.begin() + static_cast<std::ptrdiff_t>(v) * w,
                     pixels.begin() + static_cast<std::ptrdiff_t>(v + 1) * w);
      }
    }
    OniFrame* frame = getServices().acquireFrame();
    if (frame == nullptr) continue;
    const int bytes = w * h * static_cast<int>(sizeof(OniDepthPixel));
    std::memcpy(frame->data, pixels.data(), static_cast<size_t>(bytes));
    frame->dataSize = bytes;
    frame->sensorType = ONI_SENSOR_DEPTH;
    frame->timestamp = static_cast<uint64_t>(device_us);
    frame->frameIndex = static_cast<int>(++served);
    frame->width = w;
    frame->height = h;
    frame->videoMode = mode;
    frame->croppingEnabled = FALSE;
    frame->cropOriginX = 0;
    frame->cropOriginY = 0;
    frame->stride = w * static_cast<int>(sizeof(OniDepthPixel));
    raiseNewFrame(frame);
    getServices().releaseFrame(frame);
    driver_->CountFrame(device_index_);
  }
}

}  // namespace
}  // namespace kestrel::oni_plugin

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wold-style-cast"
ONI_EXPORT_DRIVER(kestrel::oni_plugin::KestrelDriver)
#pragma GCC diagnostic pop

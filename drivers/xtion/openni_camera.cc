#include "drivers/xtion/openni_camera.h"

#include <OpenNI.h>

#include <atomic>
#include <cstring>
#include <mutex>
#include <stdexcept>

namespace kestrel {

// OpenNI2 reports device events on its driver threads; the listeners only set a flag that the
// reading thread polls, keyed by the URI of the open device.
struct OpenNiDepthCamera::Impl : public openni::OpenNI::DeviceDisconnectedListener,
                                 public openni::OpenNI::DeviceStateChangedListener {
  void onDeviceDisconnected(const openni::DeviceInfo* info) override { Flag(info); }
  void onDeviceStateChanged(const openni::DeviceInfo* info, openni::DeviceState state) override {
    if (state != openni::DEVICE_STATE_OK) Flag(info);
  }
  void Flag(const openni::DeviceInfo* info) {
    std::lock_guard<std::mutex> lock(mutex);
    if (info != nullptr && watched_uri == info->getUri()) lost = true;
  }
  void Watch(const std::string& uri) {
    std::lock_guard<std::mutex> lock(mutex);
    watched_uri = uri;
    lost = false;
  }

  std::mutex mutex;
  std::string watched_uri;
  std::atomic<bool> lost{false};
  openni::Device device;
  openni::VideoStream stream;
  bool open{false};
};

OpenNiDepthCamera::OpenNiDepthCamera() : impl_(std::make_unique<Impl>()) {
  if (openni::OpenNI::initialize() != openni::STATUS_OK) {
    throw std::runtime_error(std::string("OpenNI2 initialize failed: ") +
                             openni::OpenNI::getExtendedError());
  }
  openni::OpenNI::addDeviceDisconnectedListener(impl_.get());
  openni::OpenNI::addDeviceStateChangedListener(impl_.get());
}

OpenNiDepthCamera::~OpenNiDepthCamera() {
  Close();
  openni::OpenNI::removeDeviceDisconnectedListener(impl_.get());
  openni::OpenNI::removeDeviceStateChangedListener(impl_.get());
  openni::OpenNI::shutdown();
}

bool OpenNiDepthCamera::is_open() const { return impl_->open; }
bool OpenNiDepthCamera::lost() const { return impl_->lost.load(); }

std::vector<DeviceListing> OpenNiDepthCamera::ListDevices(bool read_serials) {
  openni::Array<openni::DeviceInfo> infos;
  openni::OpenNI::enumerateDevices(&infos);
  std::vector<DeviceListing> out;
  for (int i = 0; i < infos.getSize(); ++i) {
    DeviceListing listing;
    listing.uri = infos[i].getUri();
    if (read_serials && !(impl_->open && listing.uri == uri_)) {
      openni::Device device;
      if (device.open(infos[i].getUri()) == openni::STATUS_OK) {
        char serial[ONI_MAX_STR] = {};
        int size = sizeof(serial);
        if (device.getProperty(ONI_DEVICE_PROPERTY_SERIAL_NUMBER, serial, &size) ==
            openni::STATUS_OK) {
          listing.serial.assign(serial, strnlen(serial, sizeof(serial)));
        }
        device.close();
      }
    }
    out.push_back(listing);
  }
  return out;
}

bool OpenNiDepthCamera::Open(const std::string& uri, const DepthMode& mode, std::string* error) {
  Close();
  impl_->Watch(uri);
  auto fail = [&](const std::string& what) {
    *error = what + " (" + uri + "): " + openni::OpenNI::getExtendedError();
    Close();
    return false;
  };
  if (impl_->device.open(uri.c_str()) != openni::STATUS_OK) return fail("open device");
  impl_->open = true;
  uri_ = uri;
  if (impl_->stream.create(impl_->device, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    return fail("create depth stream");
  }
  openni::VideoMode video_mode;
  video_mode.setResolution(mode.width, mode.height);
  video_mode.setFps(mode.fps);
  video_mode.setPixelFormat(mode.hundred_um ? openni::PIXEL_FORMAT_DEPTH_100_UM
                                            : openni::PIXEL_FORMAT_DEPTH_1_MM);
  if (impl_->stream.setVideoMode(video_mode) != openni::STATUS_OK) return fail("set video mode");
  // Images must not be mirrored (the optical frame is x right); some devices start mirrored.
  if (impl_->stream.isPropertySupported(openni::STREAM_PROPERTY_MIRRORING)) {
    if (impl_->stream.setMirroringEnabled(false) != openni::STATUS_OK ||
        impl_->stream.getMirroringEnabled()) {
      return fail("disable mirroring");
    }
  }
  const openni::VideoMode got = impl_->stream.getVideoMode();
  if (got.getResolutionX() != mode.width || got.getResolutionY() != mode.height ||
      got.getFps() != mode.fps || got.getPixelFormat() != video_mode.getPixelFormat()) {
    return fail("device kept a different video mode");
  }
  hfov_rad_ = impl_->stream.getHorizontalFieldOfView();
  vfov_rad_ = impl_->stream.getVerticalFieldOfView();
  if (impl_->stream.start() != openni::STATUS_OK) return fail("start depth stream");
  return true;
}

void OpenNiDepthCamera::Close() {
  if (impl_->stream.isValid()) {
    impl_->stream.stop();
    impl_->stream.destroy();
  }
  if (impl_->open) impl_->device.close();
  impl_->open = false;
  uri_.clear();
}

OpenNiDepthCamera::ReadStatus OpenNiDepthCamera::Read(int timeout_ms, DepthFrame* frame) {
  if (!impl_->open || !impl_->stream.isValid()) return ReadStatus::kError;
  openni::VideoStream* streams[] = {&impl_->stream};
  int ready = -1;
  const openni::Status wait = openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms);
  if (wait == openni::STATUS_TIME_OUT) return ReadStatus::kTimeout;
  if (wait != openni::STATUS_OK) return ReadStatus::kError;
  openni::VideoFrameRef ref;
  if (impl_->stream.readFrame(&ref) != openni::STATUS_OK || !ref.isValid()) {
    return ReadStatus::kError;
  }
  const openni::VideoMode mode = ref.getVideoMode();
  frame->device_us = static_cast<int64_t>(ref.getTimestamp());
  frame->frame_index = ref.getFrameIndex();
  frame->width = ref.getWidth();
  frame->height = ref.getHeight();
  frame->hundred_um = mode.getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM;
  const size_t pixels = static_cast<size_t>(frame->width) * static_cast<size_t>(frame->height);
  const int stride = ref.getStrideInBytes();
  if (frame->width <= 0 || frame->height <= 0 ||
      stride < frame->width * static_cast<int>(sizeof(uint16_t)) ||
      ref.getDataSize() < stride * frame->height) {
    return ReadStatus::kError;
  }
  frame->counts.resize(pixels);
  const auto* bytes = static_cast<const uint8_t*>(ref.getData());
  for (int v = 0; v < frame->height; ++v) {
    std::memcpy(frame->counts.data() + static_cast<size_t>(v) * frame->width,
                bytes + static_cast<size_t>(v) * stride,
                static_cast<size_t>(frame->width) * sizeof(uint16_t));
  }
  return ReadStatus::kFrame;
}

}  // namespace kestrel

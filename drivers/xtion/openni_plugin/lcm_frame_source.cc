#include "drivers/xtion/openni_plugin/lcm_frame_source.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <lcm/lcm-cpp.hpp>

#include "common/lcm_decode.h"
#include "kestrel/depth_image_t.hpp"
#include "lcmtypes/message_codecs.h"

namespace kestrel::oni_plugin {

std::vector<uint16_t> RescaleCounts(const std::vector<uint16_t>& counts, double from_scale_m,
                                    double to_scale_m) {
  std::vector<uint16_t> out(counts.size(), 0);
  const double ratio = from_scale_m / to_scale_m;
  for (size_t i = 0; i < counts.size(); ++i) {
    const long c = std::lround(counts[i] * ratio);
    if (c > 0 && c <= 65535) out[i] = static_cast<uint16_t>(c);
  }
  return out;
}

LcmFrameSource::LcmFrameSource(const std::string& url, const std::string& channel, bool verbose)
    : verbose_(verbose) {
  thread_ = std::thread([this, url, channel] { Run(url, channel); });
  std::unique_lock<std::mutex> lock(mutex_);
  arrived_.wait(lock, [this] { return started_; });
  if (!start_error_.empty()) {
    lock.unlock();
    thread_.join();
    throw std::runtime_error(start_error_);
  }
}

LcmFrameSource::~LcmFrameSource() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  if (thread_.joinable()) thread_.join();
}

bool LcmFrameSource::WaitNewer(int64_t after, int timeout_ms, ReceivedDepth* out) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!arrived_.wait_for(lock, std::chrono::milliseconds(timeout_ms),
                         [&] { return latest_.number > after; })) {
    return false;
  }
  *out = latest_;
  return true;
}

int64_t LcmFrameSource::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

void LcmFrameSource::Run(const std::string& url, const std::string& channel) {
  lcm::LCM lcm(url);
  GuardedSubscriptions subs(lcm);
  auto drop = [this](const std::string& reason) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++dropped_;
    if (verbose_) std::fprintf(stderr, "kestrel-oni-plugin: dropped: %s\n", reason.c_str());
  };
  {
    std::lock_guard<std::mutex> lock(mutex_);
    started_ = true;
    if (!lcm.good()) start_error_ = "cannot open LCM '" + url + "'";
  }
  arrived_.notify_all();
  if (!lcm.good()) return;
  subs.Add<depth_image_t>(
      channel,
      [this, &drop](const std::string&, const depth_image_t& m) {
        const int64_t pixels = int64_t{m.width} * m.height;
        if (m.width <= 0 || m.height <= 0 || pixels > int64_t{4096} * 4096 ||
            !(m.depth_scale_m > 0.0)) {
          drop("bad size or scale");
          return;
        }
        ReceivedDepth frame;
        frame.utime = m.utime;
        frame.width = m.width;
        frame.height = m.height;
        frame.depth_scale_m = m.depth_scale_m;
        const std::string why = DecodeDepthPixels(m, &frame.counts);
        if (!why.empty()) {
          drop(why);
          return;
        }
        {
          std::lock_guard<std::mutex> lock(mutex_);
          frame.number = latest_.number + 1;
          latest_ = std::move(frame);
        }
        arrived_.notify_all();
      },
      [&drop](const std::string&, const std::string& reason) { drop(reason); });
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) return;
    }
    lcm.handleTimeout(50);
  }
}

}  // namespace kestrel::oni_plugin

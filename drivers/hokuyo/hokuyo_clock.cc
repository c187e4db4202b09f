#include "drivers/hokuyo/hokuyo_clock.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "drivers/hokuyo/scip_codec.h"

namespace kestrel {

int64_t SensorClockUnwrapper::Unwrap(uint32_t raw_ms) {
  KESTREL_DEMAND(raw_ms < scip::kTimestampModulus);
  const int64_t raw = raw_ms;
  if (last_raw_ms_ >= 0 && last_raw_ms_ - raw > scip::kTimestampModulus / 2) ++wraps_;
  last_raw_ms_ = raw;
  return wraps_ * scip::kTimestampModulus + raw;
}

HokuyoClockModel::HokuyoClockModel(int64_t window_us, int max_windows, double max_skew)
    : window_us_(window_us), max_windows_(static_cast<size_t>(max_windows)), max_skew_(max_skew) {
  KESTREL_THROW_UNLESS(window_us > 0 && max_windows >= 3 && max_skew >= 0.0,
                       "window_us = " << window_us << ", max_windows = " << max_windows
                                      << ", max_skew = " << max_skew);
}

void HokuyoClockModel::Reset() {
  sync_offsets_us_.clear();
  sync_sensor_us_.clear();
  synced_ = false;
  offset_us_ = 0.0;
  ref_us_ = 0.0;
  skew_ = 0.0;
  min_round_trip_us_ = -1;
  sync_spread_us_ = 0.0;
  have_current_ = false;
  windows_.clear();
}

void HokuyoClockModel::AddSyncSample(int64_t send_utime, int64_t receive_utime, int64_t sensor_ms) {
  // The sensor read its clock somewhere in the round trip; the midpoint is the best guess, and
  // the reported millisecond stands for the interval [T, T + 1) ms, so its middle is T + 0.5 ms.
  const double midpoint_us = 0.5 * static_cast<double>(send_utime + receive_utime);
  const double sensor_us = static_cast<double>(sensor_ms) * 1000.0 + 500.0;
  sync_offsets_us_.push_back(midpoint_us - sensor_us);
  sync_sensor_us_.push_back(sensor_us);
  const int64_t round_trip = receive_utime - send_utime;
  if (min_round_trip_us_ < 0 || round_trip < min_round_trip_us_) min_round_trip_us_ = round_trip;
}

bool HokuyoClockModel::FinishSync() {
  if (sync_offsets_us_.empty()) return false;
  std::vector<double> sorted = sync_offsets_us_;
  std::sort(sorted.begin(), sorted.end());
  const size_t n = sorted.size();
  offset_us_ = n % 2 == 1 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  sync_spread_us_ = sorted.back() - sorted.front();
  ref_us_ = sync_sensor_us_.back();
  skew_ = 0.0;
  synced_ = true;
  have_current_ = false;
  windows_.clear();
  sync_offsets_us_.clear();
  sync_sensor_us_.clear();
  return true;
}

void HokuyoClockModel::AddStreamSample(int64_t sensor_ms, int64_t receive_utime) {
  const double x = static_cast<double>(sensor_ms) * 1000.0 + 500.0;
  const double y = static_cast<double>(receive_utime) - x;
  const int64_t index =
      static_cast<int64_t>(std::floor((x - ref_us_) / static_cast<double>(window_us_)));
  if (have_current_ && index == current_.index) {
    if (y < current_.y_us) {
      current_.x_us = x;
      current_.y_us = y;
    }
    return;
  }
  if (have_current_) {
    windows_.push_back(current_);
    while (windows_.size() > max_windows_) windows_.pop_front();
    FitSkew();
  }
  current_ = {index, x, y};
  have_current_ = true;
}

void HokuyoClockModel::FitSkew() {
  if (windows_.size() < 3) return;
  // Least-squares slope of the window minima against sensor time.
  double mx = 0.0, my = 0.0;
  for (const Window& w : windows_) {
    mx += w.x_us;
    my += w.y_us;
  }
  mx /= static_cast<double>(windows_.size());
  my /= static_cast<double>(windows_.size());
  double sxy = 0.0, sxx = 0.0;
  for (const Window& w : windows_) {
    sxy += (w.x_us - mx) * (w.y_us - my);
    sxx += (w.x_us - mx) * (w.x_us - mx);
  }
  if (sxx <= 0.0) return;
  skew_ = std::clamp(sxy / sxx, -max_skew_, max_skew_);
}

int64_t HokuyoClockModel::HostUtime(int64_t sensor_ms) const {
  KESTREL_DEMAND(synced_);
  const double sensor_us = static_cast<double>(sensor_ms) * 1000.0 + 500.0;
  return static_cast<int64_t>(std::llround(sensor_us + offset_us_ + skew_ * (sensor_us - ref_us_)));
}

}  // namespace kestrel

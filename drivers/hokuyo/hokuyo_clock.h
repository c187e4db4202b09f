#pragma once
/// @file
/// Sensor-to-host time for the Hokuyo's 24-bit millisecond clock (docs/protocols.md §1.7): unwrap
/// the counter, estimate the offset with TM1 round trips (median of sensor time minus the
/// round-trip midpoint), and track the drift while streaming. Pure: times are passed in.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

namespace kestrel {

/// Unwraps the 24-bit millisecond counter (wraps every 2^24 ms, about 4.66 h) into a
/// monotonic int64 count: a step back by more than half the range is a wrap.
class SensorClockUnwrapper {
 public:
  /// Returns the unwrapped time, ms. raw_ms must be < 2^24.
  [[nodiscard]] int64_t Unwrap(uint32_t raw_ms);
  void Reset() {
    last_raw_ms_ = -1;
    wraps_ = 0;
  }
  [[nodiscard]] int64_t wraps() const { return wraps_; }

 private:
  int64_t last_raw_ms_{-1};
  int64_t wraps_{0};
};

/// The model host_utime = T_us + offset_us + skew * (T_us - ref_us), where T_us is the middle of
/// the reported millisecond (T_ms * 1000 + 500), offset_us comes from the TM1 round trips at
/// sensor time ref_us, and skew (host seconds gained per sensor second, -drift) is the slope
/// of the per-window minimum of (receive time - T_us) against T_us while streaming: the
/// transport latency varies, its minimum over a window does not, so the minima move only with
/// the clocks' relative drift.
class HokuyoClockModel {
 public:
  /// window_us: drift window; max_windows: windows in the fit; max_skew: |skew| clamp.
  HokuyoClockModel(int64_t window_us, int max_windows, double max_skew);

  void Reset();
  /// One TM1 round trip: request written at send_utime, reply read at receive_utime, sensor
  /// time sensor_ms (unwrapped).
  void AddSyncSample(int64_t send_utime, int64_t receive_utime, int64_t sensor_ms);
  /// Sets the offset to the median of the samples' offsets. Returns false if there are none.
  bool FinishSync();
  /// A scan stamped sensor_ms (unwrapped) whose reply was read at receive_utime.
  void AddStreamSample(int64_t sensor_ms, int64_t receive_utime);

  /// Host time of sensor time sensor_ms (unwrapped), us. Requires a finished sync.
  [[nodiscard]] int64_t HostUtime(int64_t sensor_ms) const;
  [[nodiscard]] bool synced() const { return synced_; }
  /// host - sensor at ref, us.
  [[nodiscard]] double offset_us() const { return offset_us_; }
  /// Estimated drift of the sensor clock relative to the host, 1e-6 (positive: sensor fast).
  [[nodiscard]] double drift_ppm() const { return -skew_ * 1e6; }
  /// Smallest TM1 round trip of the last sync, us (-1 if none).
  [[nodiscard]] int64_t min_round_trip_us() const { return min_round_trip_us_; }
  /// Spread of the sync offsets (max - min), us.
  [[nodiscard]] double sync_spread_us() const { return sync_spread_us_; }

 private:
  struct Window {
    int64_t index;
    double x_us;  // T_us at the minimum
    double y_us;  // minimum of receive - T_us
  };
  void FitSkew();

  int64_t window_us_;
  size_t max_windows_;
  double max_skew_;
  std::vector<double> sync_offsets_us_;
  std::vector<double> sync_sensor_us_;
  bool synced_{false};
  double offset_us_{0.0};
  double ref_us_{0.0};
  double skew_{0.0};
  int64_t min_round_trip_us_{-1};
  double sync_spread_us_{0.0};
  bool have_current_{false};
  Window current_{};
  std::deque<Window> windows_;
};

}  // namespace kestrel

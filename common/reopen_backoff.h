#pragma once
/// @file
/// When a driver tries its device again (a serial port, an I2C bus): the first retry min_s after
/// a failure, the delay doubling at each failure up to max_s, and back to min_s once the device
/// works. Pure: times are passed in.

#include <cstdint>
#include <string>

namespace kestrel {

class ReopenBackoff {
 public:
  /// @throws std::invalid_argument naming `owner`'s keys unless 0 < min_s <= max_s.
  ReopenBackoff(double min_s, double max_s, const std::string& owner);
  /// Checks the pair as the constructor does (for a configuration's Validate).
  static void Validate(double min_s, double max_s, const std::string& owner);

  /// A failure at now_utime: the next attempt is due the current delay later; the delay doubles.
  void Failed(int64_t now_utime);
  /// The device works: the next failure waits min_s again.
  void Succeeded() { delay_s_ = min_s_; }
  /// True once the next attempt is due (at once before any failure).
  [[nodiscard]] bool Due(int64_t now_utime) const { return now_utime >= next_utime_; }
  /// When the next attempt is due, us.
  [[nodiscard]] int64_t next_utime() const { return next_utime_; }
  /// The delay the next failure will wait, s.
  [[nodiscard]] double delay_s() const { return delay_s_; }

 private:
  double min_s_;
  double max_s_;
  double delay_s_;
  int64_t next_utime_{0};
};

}  // namespace kestrel

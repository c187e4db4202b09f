#pragma once
/// @file
/// Pose/scan synchronisation (docs/design.md §5.2): a short history of time-stamped poses X_WB and
/// interpolation (linear position, slerp orientation: common/se3.h Interpolate) at a scan's
/// stamp. Pure: no clock; the caller passes times. Lookup results:
///  - kOk:      bracketing poses found, spaced at most max_gap_s apart; pose interpolated
///              (a stamp equal to a stored pose's gives that pose exactly);
///  - kWait:    the stamp is newer than the latest pose: hold the scan and ask again after the
///              next pose, as long as now - stamp <= max_wait_s;
///  - kTooOld:  the stamp is older than the oldest pose kept (skip and count);
///  - kGap:     the bracketing poses are more than max_gap_s apart (motion capture lost the
///              vehicle), or the wait for a newer pose expired (skip and count).

#include <cstdint>
#include <deque>

#include "common/se3.h"

namespace kestrel {

/// Parameters of the pose history.
struct PoseHistoryConfig {
  double history_s{2.0};   ///< poses older than latest - history_s are dropped, s
  double max_gap_s{0.1};   ///< largest spacing of bracketing poses to interpolate across, s
  double max_wait_s{0.2};  ///< longest a scan newer than the latest pose may wait, s

  /// @throws std::invalid_argument unless all are positive and finite and
  /// max_gap_s <= history_s.
  void Validate() const;
};

/// Outcome of a lookup (file comment).
enum class PoseLookupResult { kOk, kWait, kTooOld, kGap };

/// Short name of a result ("ok", "wait", "too_old", "gap") for status messages.
[[nodiscard]] const char* ToString(PoseLookupResult result);

/// Time-stamped poses in increasing stamp order.
class PoseHistory {
 public:
  /// @throws std::invalid_argument if config.Validate() throws.
  explicit PoseHistory(const PoseHistoryConfig& config);

  /// Adds X_WB measured at utime (us). Poses must arrive in increasing time: a pose not newer
  /// than the latest is rejected (returns false, counted in rejected_out_of_order()). Drops
  /// poses older than utime - history_s, keeping at least the newest one before that bound so
  /// that a stamp just inside the history can still be bracketed.
  bool Add(int64_t utime, const Pose3& X_WB);

  /// The pose at `stamp_us` (file comment). `now_us` is the caller's clock, used only to
  /// bound the wait. *X_WB is written on kOk only.
  [[nodiscard]] PoseLookupResult Lookup(int64_t stamp_us, int64_t now_us, Pose3* X_WB) const;

  /// Number of poses held.
  [[nodiscard]] size_t size() const { return poses_.size(); }
  /// Stamp of the newest pose held, us (INT64_MIN when none is).
  [[nodiscard]] int64_t newest_utime() const {
    return poses_.empty() ? INT64_MIN : poses_.back().utime;
  }
  /// Poses refused because they were not newer than the latest.
  [[nodiscard]] uint64_t rejected_out_of_order() const { return rejected_out_of_order_; }

 private:
  struct Stamped {
    int64_t utime;
    Pose3 X_WB;
  };
  PoseHistoryConfig config_;
  std::deque<Stamped> poses_;
  uint64_t rejected_out_of_order_{0};
};

}  // namespace kestrel

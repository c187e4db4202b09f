#include "mapping/pose_history.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"

namespace kestrel {

void PoseHistoryConfig::Validate() const {
  KESTREL_THROW_UNLESS(std::isfinite(history_s) && history_s > 0.0,
                       "pose history history_s = " << history_s << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(std::isfinite(max_gap_s) && max_gap_s > 0.0 && max_gap_s <= history_s,
                       "pose history max_gap_s = " << max_gap_s << ", accepted (0, history_s = "
                                                   << history_s << "]");
  KESTREL_THROW_UNLESS(std::isfinite(max_wait_s) && max_wait_s > 0.0,
                       "pose history max_wait_s = " << max_wait_s << ", accepted (0, inf)");
}

const char* ToString(PoseLookupResult result) {
  switch (result) {
    case PoseLookupResult::kOk:
      return "ok";
    case PoseLookupResult::kWait:
      return "wait";
    case PoseLookupResult::kTooOld:
      return "too_old";
    case PoseLookupResult::kGap:
      return "gap";
  }
  return "unknown";
}

PoseHistory::PoseHistory(const PoseHistoryConfig& config) : config_(config) { config_.Validate(); }

bool PoseHistory::Add(int64_t utime, const Pose3& X_WB) {
  if (!poses_.empty() && utime <= poses_.back().utime) {
    ++rejected_out_of_order_;
    return false;
  }
  poses_.push_back({utime, X_WB});
  const int64_t oldest_kept = utime - static_cast<int64_t>(std::llround(config_.history_s * 1e6));
  // Keep the last pose at or before the bound: it brackets stamps just after the bound.
  while (poses_.size() >= 2 && poses_[1].utime <= oldest_kept) poses_.pop_front();
  return true;
}

PoseLookupResult PoseHistory::Lookup(int64_t stamp_us, int64_t now_us, Pose3* X_WB) const {
  if (poses_.empty() || stamp_us > poses_.back().utime) {
    const double waited_s = 1e-6 * static_cast<double>(now_us - stamp_us);
    return waited_s <= config_.max_wait_s ? PoseLookupResult::kWait : PoseLookupResult::kGap;
  }
  if (stamp_us < poses_.front().utime) return PoseLookupResult::kTooOld;
  // First pose with utime >= stamp (exists: stamp <= back).
  const auto after = std::lower_bound(poses_.begin(), poses_.end(), stamp_us,
                                      [](const Stamped& s, int64_t t) { return s.utime < t; });
  if (after->utime == stamp_us) {
    *X_WB = after->X_WB;
    return PoseLookupResult::kOk;
  }
  const auto before = after - 1;
  const int64_t spacing_us = after->utime - before->utime;
  if (1e-6 * static_cast<double>(spacing_us) > config_.max_gap_s) return PoseLookupResult::kGap;
  const double s = static_cast<double>(stamp_us - before->utime) / static_cast<double>(spacing_us);
  *X_WB = Interpolate(before->X_WB, after->X_WB, s);  // linear + slerp
  return PoseLookupResult::kOk;
}

}  // namespace kestrel

#include "common/reopen_backoff.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "common/clock.h"

namespace kestrel {

void ReopenBackoff::Validate(double min_s, double max_s, const std::string& owner) {
  KESTREL_THROW_UNLESS(std::isfinite(max_s) && min_s > 0.0 && max_s >= min_s,
                       owner << ": 0 < reopen_backoff_min_s (" << min_s
                             << ") <= reopen_backoff_max_s (" << max_s << ")");
}

ReopenBackoff::ReopenBackoff(double min_s, double max_s, const std::string& owner)
    : min_s_(min_s), max_s_(max_s), delay_s_(min_s) {
  Validate(min_s, max_s, owner);
}

void ReopenBackoff::Failed(int64_t now_utime) {
  next_utime_ = now_utime + SecondsToUtime(delay_s_);
  delay_s_ = std::min(2.0 * delay_s_, max_s_);
}

}  // namespace kestrel

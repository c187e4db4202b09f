#include "common/clock.h"

#include <cmath>
#include <ctime>

#include "common/check.h"

namespace kestrel {

int64_t WallClock::NowUtime() const {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

void SimClock::SetUtime(int64_t utime) {
  const int64_t now = utime_.load();
  KESTREL_THROW_UNLESS(utime >= now,
                       "SimClock cannot go backwards: now " << now << " us, asked " << utime);
  utime_.store(utime);
}

void SimClock::AdvanceUtime(int64_t dt_us) {
  KESTREL_THROW_UNLESS(dt_us >= 0, "SimClock step must be >= 0, got " << dt_us << " us");
  utime_.fetch_add(dt_us);
}

int64_t SecondsToUtime(double seconds) { return std::llround(seconds * 1e6); }

}  // namespace kestrel

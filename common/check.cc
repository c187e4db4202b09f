#include "common/check.h"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace kestrel::internal {

[[noreturn]] __attribute__((cold)) void DemandFailed(const char* condition, const char* file,
                                                     int line) {
  std::fprintf(stderr, "kestrel: invariant failed: %s at %s:%d\n", condition, file, line);
  std::abort();
}

[[noreturn]] __attribute__((cold)) void ThrowUnlessFailed(const char* condition, const char* file,
                                                          int line, const std::string& message) {
  throw std::invalid_argument(message + " (requires " + condition + ", " + file + ":" +
                              std::to_string(line) + ")");
}

}  // namespace kestrel::internal

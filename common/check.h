#pragma once
/// @file
/// Three strengths of check (after Drake's drake_assert.h / drake_throw.h):
///  - KESTREL_DEMAND(cond): always on, for cheap invariants; aborts with file, line and condition.
///  - KESTREL_ASSERT(cond): compiled out of Release (NDEBUG), for per-cell loops.
///  - KESTREL_THROW_UNLESS(cond, message): for caller input; throws std::invalid_argument whose
///    text holds the condition and the message. The failure paths are out of line (cold).

#include <sstream>
#include <string>

namespace kestrel::internal {
[[noreturn]] void DemandFailed(const char* condition, const char* file, int line);
[[noreturn]] void ThrowUnlessFailed(const char* condition, const char* file, int line,
                                    const std::string& message);
}  // namespace kestrel::internal

#define KESTREL_DEMAND(condition)                                        \
  do {                                                                   \
    if (!(condition)) {                                                  \
      ::kestrel::internal::DemandFailed(#condition, __FILE__, __LINE__); \
    }                                                                    \
  } while (0)

#ifdef NDEBUG
#define KESTREL_ASSERT(condition) \
  do {                            \
  } while (0)
#else
#define KESTREL_ASSERT(condition) KESTREL_DEMAND(condition)
#endif

/// `message` is a stream expression: KESTREL_THROW_UNLESS(x > 0, "x = " << x).
#define KESTREL_THROW_UNLESS(condition, message)                                 \
  do {                                                                           \
    if (!(condition)) {                                                          \
      std::ostringstream kestrel_throw_stream_;                                  \
      kestrel_throw_stream_ << message; /* NOLINT(bugprone-macro-parentheses) */ \
      ::kestrel::internal::ThrowUnlessFailed(#condition, __FILE__, __LINE__,     \
                                             kestrel_throw_stream_.str());       \
    }                                                                            \
  } while (0)

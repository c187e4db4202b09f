#pragma once
/// @file
/// The largest single allocation a piece of code makes (LargestAllocation): the tests that show a
/// decoder refuses a malformed size before allocating it. Replaces the global operator new and
/// delete, so include it in exactly one source file of a test binary.

#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <new>

// The replacement operator new below pairs malloc with free on purpose.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

namespace kestrel::testing::allocation_watch {
inline std::atomic<bool> watching{false};
inline std::atomic<size_t> largest{0};
}  // namespace kestrel::testing::allocation_watch

void* operator new(size_t size) {
  namespace w = kestrel::testing::allocation_watch;
  if (w::watching.load(std::memory_order_relaxed)) {
    size_t prev = w::largest.load();
    while (size > prev && !w::largest.compare_exchange_weak(prev, size)) {
    }
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t /*size*/) noexcept { std::free(p); }

namespace kestrel::testing {

/// The largest single allocation `f` makes, bytes.
template <class F>
size_t LargestAllocation(F&& f) {
  allocation_watch::largest = 0;
  allocation_watch::watching = true;
  f();
  allocation_watch::watching = false;
  return allocation_watch::largest.load();
}

}  // namespace kestrel::testing

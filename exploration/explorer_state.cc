#include "exploration/explorer_state.h"

#include <array>

namespace kestrel {
namespace {

// The one table of names, by value.
constexpr std::array<const char*, kExplorerStateCount> kNames{"waiting",   "startup", "exploring",
                                                              "returning", "done",    "failed"};

}  // namespace

const char* ToString(ExplorerState state) {
  const int v = static_cast<int>(state);
  return v >= 0 && v < kExplorerStateCount ? kNames[static_cast<size_t>(v)] : "unknown";
}

std::optional<ExplorerState> ExplorerStateFromName(const std::string& name) {
  for (int v = 0; v < kExplorerStateCount; ++v) {
    if (name == kNames[static_cast<size_t>(v)]) return static_cast<ExplorerState>(v);
  }
  return std::nullopt;
}

std::optional<ExplorerState> ExplorerStateFromValue(int value) {
  if (value < 0 || value >= kExplorerStateCount) return std::nullopt;
  return static_cast<ExplorerState>(value);
}

std::string ExplorerStateName(int value) {
  const std::optional<ExplorerState> s = ExplorerStateFromValue(value);
  return s ? ToString(*s) : "state " + std::to_string(value);
}

}  // namespace kestrel

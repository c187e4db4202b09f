#pragma once
/// @file
/// The explorer's states and their names: the one table that the explorer's status and state
/// file, kestrel-mission's progress lines, the viewer (through kestrel-viewer's JSON) and
/// kestrel-report (through kestrel-report-export's CSV files) read. Values as
/// exploration_status_t::STATE_* (the node maps them, as control/safety.h's FlightMode).

#include <cstdint>
#include <optional>
#include <string>

namespace kestrel {

/// WAITING -> STARTUP -> EXPLORING -> RETURNING -> DONE (exploration/explorer.h).
enum class ExplorerState : int8_t {
  kWaiting = 0,    ///< no map, pose or airborne vehicle yet; or a start-up not flown
  kStartup = 1,    ///< the start-up turn: a full circle to scan
  kExploring = 2,  ///< planning and flying to the next pose
  kReturning = 3,  ///< exploration ended: flying home
  kDone = 4,       ///< the land command sent
  kFailed = 5,     ///< in the message contract; the explorer does not enter it today
};

/// How many states there are (the table's size).
inline constexpr int kExplorerStateCount = 6;

/// "waiting", "startup", "exploring", "returning", "done", "failed"; "unknown" for a value outside
/// the table.
[[nodiscard]] const char* ToString(ExplorerState state);

/// The state named `name` (one of ToString's names), nullopt for any other text.
[[nodiscard]] std::optional<ExplorerState> ExplorerStateFromName(const std::string& name);

/// The state of a status message's value (exploration_status_t::state), nullopt outside the table.
[[nodiscard]] std::optional<ExplorerState> ExplorerStateFromValue(int value);

/// The name of a status message's state value: ToString of it, or "state <value>" outside the
/// table.
[[nodiscard]] std::string ExplorerStateName(int value);

}  // namespace kestrel

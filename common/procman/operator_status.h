#pragma once
/// @file
/// The operator's one-screen view (kestrel-cmd status): the latest heartbeat of every process,
/// every process-sheet runner's commands, and the controller's mode, from what arrived on LCM.

#include <cstdint>
#include <map>
#include <string>

#include "kestrel/controller_status_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/procman_status_t.hpp"

namespace kestrel::procman {

/// The newest message of each source, kept for display.
struct OperatorView {
  std::map<std::string, heartbeat_t> heartbeats;    ///< by channel
  std::map<std::string, procman_status_t> runners;  ///< by runner host
  bool has_controller{false};
  controller_status_t controller;
};

/// Human-readable names of the enumerations.
[[nodiscard]] std::string HeartbeatStateName(int8_t state);
[[nodiscard]] std::string CommandStateName(int8_t state);
[[nodiscard]] std::string ControllerModeName(int8_t mode);

/// Formats the view as a fixed-width table; ages are relative to `now_utime`.
[[nodiscard]] std::string FormatOperatorView(const OperatorView& view, int64_t now_utime);

}  // namespace kestrel::procman

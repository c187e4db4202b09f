#include "common/procman/operator_status.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace kestrel::procman {

std::string HeartbeatStateName(int8_t state) {
  switch (state) {
    case heartbeat_t::STATE_STARTING:
      return "starting";
    case heartbeat_t::STATE_OK:
      return "ok";
    case heartbeat_t::STATE_DEGRADED:
      return "DEGRADED";
    case heartbeat_t::STATE_FAILED:
      return "FAILED";
    case heartbeat_t::STATE_STOPPING:
      return "stopping";
    default:
      return "state " + std::to_string(state);
  }
}

std::string CommandStateName(int8_t state) {
  switch (state) {
    case procman_command_t::STATE_STOPPED:
      return "stopped";
    case procman_command_t::STATE_RUNNING:
      return "running";
    case procman_command_t::STATE_STOPPING:
      return "stopping";
    case procman_command_t::STATE_RESPAWN_WAIT:
      return "RESPAWNING";
    case procman_command_t::STATE_EXITED:
      return "EXITED";
    default:
      return "state " + std::to_string(state);
  }
}

std::string ControllerModeName(int8_t mode) {
  switch (mode) {
    case controller_status_t::MODE_IDLE:
      return "idle";
    case controller_status_t::MODE_TAKEOFF:
      return "takeoff";
    case controller_status_t::MODE_TRACK:
      return "track";
    case controller_status_t::MODE_HOLD:
      return "hold";
    case controller_status_t::MODE_LAND:
      return "land";
    case controller_status_t::MODE_ESTOP:
      return "E-STOP";
    default:
      return "mode " + std::to_string(mode);
  }
}

std::string FormatOperatorView(const OperatorView& view, int64_t now_utime) {
  std::ostringstream out;
  char line[512];
  out << "PROCESSES (heartbeats)\n";
  std::snprintf(line, sizeof(line), "  %-22s %-12s %-9s %7s %9s  %s\n", "process", "host", "state",
                "age s", "uptime s", "last error");
  out << line;
  if (view.heartbeats.empty()) out << "  (no heartbeat received)\n";
  for (const auto& [channel, hb] : view.heartbeats) {
    std::snprintf(line, sizeof(line), "  %-22s %-12s %-9s %7.1f %9.1f  %s\n", hb.process.c_str(),
                  hb.host.c_str(), HeartbeatStateName(hb.state).c_str(),
                  static_cast<double>(now_utime - hb.utime) * 1e-6, hb.uptime_s,
                  hb.last_error.c_str());
    out << line;
  }
  out << "\nRUNNERS (process sheets)\n";
  if (view.runners.empty()) out << "  (no runner status received)\n";
  for (const auto& [host, st] : view.runners) {
    out << "  host " << host << "  sheet " << st.sheet
        << (st.script.empty() ? "" : "  script " + st.script) << "\n";
    for (const auto& c : st.commands) {
      std::snprintf(line, sizeof(line),
                    "    %-20s %-11s pid %-7d exit %-4d restarts %-3d cpu %5.1f%% rss %7.1f MiB\n",
                    c.id.c_str(), CommandStateName(c.state).c_str(), c.pid, c.exit_code, c.restarts,
                    c.cpu_percent, c.rss_mb);
      out << line;
    }
  }
  out << "\nCONTROLLER\n";
  if (!view.has_controller) {
    out << "  (no controller status received)\n";
  } else {
    const auto& c = view.controller;
    std::snprintf(
        line, sizeof(line),
        "  mode %s (%s)  position %.2f %.2f %.2f m  |e_x| %.3f m  pose age %.2f s\n",
        ControllerModeName(c.mode).c_str(), c.reason.c_str(), c.position_m[0], c.position_m[1],
        c.position_m[2],
        std::sqrt(c.e_x_m[0] * c.e_x_m[0] + c.e_x_m[1] * c.e_x_m[1] + c.e_x_m[2] * c.e_x_m[2]),
        c.pose_age_s);
    out << line;
  }
  return out.str();
}

}  // namespace kestrel::procman

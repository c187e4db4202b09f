// kestrel-cmd: the operator tool. Vehicle commands (take off, hold, land, e-stop) on COMMAND,
// process-sheet orders to the runners on every host, and a one-screen status of every process.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include <lcm/lcm-cpp.hpp>

#include "common/clock.h"
#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/identity.h"
#include "common/lcm_decode.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/procman/operator_status.h"
#include "common/procman/sheriff.h"
#include "common/trajectory.h"
#include "common/trajectory_message.h"
#include "kestrel/command_t.hpp"
#include "kestrel/trajectory_t.hpp"

namespace {
const char* const kUsage =
    "usage: kestrel-cmd takeoff [--height M] | hold | land | estop | idle | track\n"
    "                   [--vehicle PREFIX|all | --channel COMMAND] [--wait SECONDS]\n"
    "       kestrel-cmd goto X Y Z [--relative] [--duration S] [--vehicle PREFIX] [--wait S]\n"
    "       kestrel-cmd status [--seconds S]\n"
    "       kestrel-cmd params [PROCESS] [--seconds S]\n"
    "       kestrel-cmd procman list [--seconds S]\n"
    "       kestrel-cmd procman load SHEET [--host HOST] [--seconds S]\n"
    "       kestrel-cmd procman start|stop|restart TARGET [--host HOST] [--seconds S]\n"
    "       kestrel-cmd procman output TARGET [--host HOST] [--seconds S]\n"
    "  procman: a bot-procman sheriff without a GUI (libbot2's protocol: PMD_INFO2, PMD_ORDERS2,\n"
    "           PMD_PRINTF), for kestrel-procman runners and libbot2 bot-procman deputies alike.\n"
    "           list: every deputy's report within S seconds (default 2).\n"
    "           load: creates SHEET's commands (only HOST's if given) on the deputies named by\n"
    "           their hosts, stopped, and brings the settings of those a deputy has to the\n"
    "           sheet's (other commands are kept); exit 1 if a host's deputy did not report.\n"
    "           start|stop|restart: orders every deputy holding TARGET (only HOST's if given).\n"
    "           load and the orders wait up to S seconds (default 10) for the deputies' reports\n"
    "           to show them done; exit 1 if not.\n"
    "           output: prints what the commands of TARGET write (PMD_PRINTF), each line after\n"
    "           its command's name, until Ctrl-C (or for S seconds)\n"
    "  TARGET: all | cmd:ID | group:PATH (output: also ID)\n"
    "  --wait S: wait up to S seconds for CONTROLLER_STATUS to show the commanded mode; exit 1\n"
    "            if it does not (the e-stop is always sent at once, and repeated 3 times)\n"
    "  --vehicle PREFIX: command the vehicle whose channels carry PREFIX (PREFIXCOMMAND, its\n"
    "            status on PREFIXCONTROLLER_STATUS); all: every controller that reports a\n"
    "            status within 0.3 s (each *CONTROLLER_STATUS channel), each on its own channel\n"
    "  goto: a straight rest-to-rest move (common/trajectory.h RestToRest) from the flying\n"
    "        controller's set point to X Y Z (world frame, m) at its heading, on TRAJECTORY;\n"
    "        --relative: X Y Z from the set point; --duration S (default: 0.5 m/s on\n"
    "        average, at least 2 s); --wait S: until the\n"
    "        controller reports it flown, exit 1 if not\n"
    "  params: asks every process (or PROCESS, e.g. kestrel-mapper) for the configuration it runs\n"
    "          with and prints each answer that comes within S seconds; exit 1 if none does\n"
    "  SIGINT (Ctrl-C) or SIGTERM ends any wait at once: exit 128 + the signal\n";

/// Listens for `seconds` and collects the operator view.
kestrel::procman::OperatorView Listen(lcm::LCM& lcm, double seconds) {
  using namespace kestrel;
  procman::OperatorView view;
  GuardedSubscriptions subs(lcm);
  auto ignore = [](const std::string&, const std::string&) {};
  subs.Add<heartbeat_t>(
      "HEARTBEAT_.*", [&](const std::string& ch, const heartbeat_t& m) { view.heartbeats[ch] = m; },
      ignore);
  subs.Add<procman_status_t>(
      "PROCMAN_STATUS",
      [&](const std::string&, const procman_status_t& m) { view.runners[m.host] = m; }, ignore);
  subs.Add<controller_status_t>(
      "CONTROLLER_STATUS",
      [&](const std::string&, const controller_status_t& m) {
        view.has_controller = true;
        view.controller = m;
      },
      ignore);
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000));
  while (std::chrono::steady_clock::now() < end && !kestrel::NodeLoop::signal_received()) {
    lcm.handleTimeout(50);
  }
  return view;
}
/// kestrel-cmd goto: waits up to 1 s for the controller's status, sends a rest-to-rest move from
/// its set point (estimate minus position error) to words[1..3], and with wait_s > 0 waits for the
/// controller to report that trajectory done. Returns the exit code.
int GoTo(lcm::LCM& lcm, const kestrel::Clock& clock, const std::string& prefix,
         const std::vector<std::string>& words, bool relative, double duration_s, double wait_s) {
  using namespace kestrel;
  Eigen::Vector3d to;
  for (int i = 0; i < 3; ++i) {
    char* end = nullptr;
    to[i] = std::strtod(words[1 + i].c_str(), &end);
    if (end == words[1 + i].c_str() || *end != '\0' || !std::isfinite(to[i])) {
      std::fprintf(stderr, "kestrel-cmd: goto: '%s' is not a coordinate in m\n",
                   words[1 + i].c_str());
      return 2;
    }
  }
  const std::string status_channel = prefix + "CONTROLLER_STATUS";
  controller_status_t status{};
  bool have_status = false;
  GuardedSubscriptions subs(lcm);
  subs.Add<controller_status_t>(
      status_channel,
      [&](const std::string&, const controller_status_t& m) {
        status = m;
        have_status = true;
      },
      nullptr);
  const auto handle_until = [&](double seconds, const std::function<bool()>& done) {
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000));
    while (!done() && std::chrono::steady_clock::now() < end &&
           !kestrel::NodeLoop::signal_received()) {
      lcm.handleTimeout(20);
    }
  };
  handle_until(1.0, [&] { return have_status; });
  if (!have_status) {
    std::fprintf(stderr, "kestrel-cmd: goto: no status on %s within 1 s\n", status_channel.c_str());
    return 1;
  }
  if (status.mode != controller_status_t::MODE_HOLD &&
      status.mode != controller_status_t::MODE_TRACK) {
    std::fprintf(stderr, "kestrel-cmd: goto: the controller is not flying (mode %d): take off\n",
                 status.mode);
    return 1;
  }
  // The set point x_d = x - e_x; the heading from the estimated attitude (hovering: the set one).
  Eigen::Vector3d from;
  for (int i = 0; i < 3; ++i) from[i] = status.position_m[i] - status.e_x_m[i];
  const double* q = status.orientation_wxyz;
  const double yaw =
      std::atan2(2.0 * (q[0] * q[3] + q[1] * q[2]), 1.0 - 2.0 * (q[2] * q[2] + q[3] * q[3]));
  if (relative) to += from;
  if (duration_s <= 0.0) duration_s = std::max(2.0, (to - from).norm() / 0.5);
  const int64_t now = clock.NowUtime();
  std::string error;
  const auto move = RestToRest(UtimeToSeconds(now), from, to, yaw, duration_s, &error);
  if (!move.has_value()) {
    std::fprintf(stderr, "kestrel-cmd: goto: %s\n", error.c_str());
    return 1;
  }
  const trajectory_t msg = ToMessage(*move, now, now, NewPublisherEpoch());
  lcm.publish(prefix + "TRAJECTORY", &msg);
  std::printf("sent goto (%.2f, %.2f, %.2f) -> (%.2f, %.2f, %.2f) in %.1f s on %sTRAJECTORY\n",
              from.x(), from.y(), from.z(), to.x(), to.y(), to.z(), duration_s, prefix.c_str());
  if (wait_s <= 0) return 0;
  bool flown = false;
  subs.Add<controller_status_t>(
      status_channel,
      [&](const std::string&, const controller_status_t& m) {
        flown = flown || (m.trajectory_seq == msg.seq && m.trajectory_epoch == msg.epoch &&
                          m.trajectory_done);
      },
      nullptr);
  handle_until(wait_s, [&] { return flown; });
  std::printf("%s\n", flown ? "controller flew it" : "controller did NOT fly it");
  return flown ? 0 : 1;
}
}  // namespace

/// The target words of kestrel-cmd procman: all, cmd:ID, group:PATH (and a bare ID where
/// `bare_is_command`). Returns false if malformed.
bool ParseTarget(const std::string& t, bool bare_is_command, kestrel::procman::CommandTarget* out) {
  if (t.rfind("cmd:", 0) == 0) {
    *out = {false, t.substr(4)};
  } else if (t.rfind("group:", 0) == 0) {
    *out = {true, t.substr(6)};
  } else if (t == "all") {
    *out = {true, ""};
  } else if (bare_is_command && !t.empty()) {
    *out = {false, t};
  } else {
    return false;
  }
  return true;
}

/// kestrel-cmd procman list|load|start|stop|restart|output (a bot-procman sheriff,
/// docs/protocols.md §5.4). `seconds` < 0: the verb's default. Returns the exit code.
int Procman(lcm::LCM& lcm, const kestrel::Clock& clock, const std::vector<std::string>& p,
            const std::string& host, double seconds) {
  using namespace kestrel;
  char hostname[256] = "";
  gethostname(hostname, sizeof(hostname) - 1);
  const double wait_for = seconds >= 0 ? seconds : (p[1] == "list" ? 2.0 : 10.0);
  // Orders are dropped a second after this tool stops waiting for them.
  procman::Sheriff sheriff(lcm, clock,
                           std::string(hostname) + ":" + std::to_string(getpid()) + ":" +
                               std::to_string(clock.NowUtime()),
                           wait_for + 1.0);
  sheriff.Discover();
  const auto poll_for = [&](double s, const std::function<bool()>& done) {
    const int64_t end = clock.NowUtime() + static_cast<int64_t>(s * 1e6);
    while (clock.NowUtime() < end && !done() && !NodeLoop::signal_received()) {
      lcm.handleTimeout(50);
      sheriff.Poll();
    }
  };
  // Every deputy reports within a second of the discovery request (at most 1 s later by its own
  // timer); ordering one that has not reported would drop its commands.
  const auto hear_deputies = [&] { poll_for(std::min(wait_for, 1.2), [] { return false; }); };
  const auto interrupted = [] { return NodeLoop::ExitCodeForSignal(NodeLoop::received_signal()); };
  // Waits for the orders to be carried out and says so per deputy.
  const auto confirm = [&](const std::vector<std::string>& ordered, const std::string& what) {
    poll_for(wait_for, [&] { return sheriff.Pending().empty(); });
    const std::vector<std::string> pending = sheriff.Pending();
    for (const std::string& deputy : ordered) {
      const bool done = std::find(pending.begin(), pending.end(), deputy) == pending.end();
      std::printf("%s on %s: %s\n", what.c_str(), deputy.c_str(), done ? "done" : "not confirmed");
    }
    if (NodeLoop::signal_received()) return interrupted();
    return pending.empty() ? 0 : 1;
  };
  if (p[1] == "list" && p.size() == 2) {
    poll_for(wait_for, [] { return false; });
    std::printf("%s", procman::FormatDeputies(sheriff.deputies(), clock.NowUtime()).c_str());
    if (NodeLoop::signal_received()) return interrupted();
    return sheriff.deputies().empty() ? 1 : 0;
  }
  if (p[1] == "load" && p.size() == 3) {
    const procman::Sheet sheet = procman::LoadSheet(p[2]);  // refused: "FILE:LINE: reason"
    hear_deputies();
    const std::vector<std::string> missing = sheriff.Load(sheet, host);
    for (const std::string& h : missing) {
      std::fprintf(stderr,
                   "kestrel-cmd: no deputy named %s reported: its commands in %s were not "
                   "loaded\n",
                   h.c_str(), p[2].c_str());
    }
    std::vector<std::string> ordered;  // the sheet's hosts that reported
    for (const procman::Command& c : sheet.commands) {
      if ((host.empty() || c.host == host) && sheriff.deputies().count(c.host) != 0 &&
          std::find(ordered.begin(), ordered.end(), c.host) == ordered.end()) {
        ordered.push_back(c.host);
      }
    }
    const int code = confirm(ordered, "load " + p[2]);
    return code != 0 ? code : (missing.empty() ? 0 : 1);
  }
  const std::map<std::string, procman::SheriffVerb> verbs = {
      {"start", procman::SheriffVerb::kStart},
      {"stop", procman::SheriffVerb::kStop},
      {"restart", procman::SheriffVerb::kRestart}};
  procman::CommandTarget target;
  if (verbs.count(p[1]) != 0 && p.size() == 3) {
    if (!ParseTarget(p[2], false, &target)) {
      std::fprintf(stderr, "kestrel-cmd: TARGET must be all, cmd:ID or group:PATH\n");
      return 2;
    }
    hear_deputies();
    const std::vector<std::string> ordered = sheriff.Order(verbs.at(p[1]), target, host);
    if (ordered.empty()) {
      std::fprintf(stderr, "kestrel-cmd: no deputy%s reported a command matching %s\n",
                   host.empty() ? "" : (" named " + host).c_str(), p[2].c_str());
      return NodeLoop::signal_received() ? interrupted() : 1;
    }
    return confirm(ordered, p[1] + " " + p[2]);
  }
  if (p[1] == "output" && p.size() == 3) {
    if (!ParseTarget(p[2], true, &target)) {
      std::fprintf(stderr, "kestrel-cmd: TARGET must be all, cmd:ID, group:PATH or ID\n");
      return 2;
    }
    // Each line of a command's output after its name, as libbot2's sheriff console shows it; a
    // line cut across two printf_t is held until its end comes.
    std::map<std::pair<std::string, std::string>, std::string> partial;
    sheriff.FollowOutput([&](const std::string& deputy, const std::string& command,
                             const bot_procman::printf_t& m) {
      if (!host.empty() && deputy != host) return;
      const bot_procman::deputy_cmd2_t* reported = sheriff.Reported(deputy, command);
      if (command.empty() || reported == nullptr || !target.Matches(command, reported->cmd.group)) {
        return;
      }
      std::string& text = partial[{deputy, command}];
      text += m.text;
      for (size_t newline = text.find('\n'); newline != std::string::npos;
           newline = text.find('\n')) {
        std::printf("[%s %s] %s\n", deputy.c_str(), command.c_str(),
                    text.substr(0, newline).c_str());
        text.erase(0, newline + 1);
      }
      std::fflush(stdout);
    });
    poll_for(seconds >= 0 ? seconds : 1e9, [] { return false; });
    for (const auto& [key, text] : partial) {
      if (!text.empty())
        std::printf("[%s %s] %s\n", key.first.c_str(), key.second.c_str(), text.c_str());
    }
    return NodeLoop::signal_received() ? interrupted() : 0;
  }
  std::fprintf(stderr, "kestrel-cmd: unknown procman command\n%s", kUsage);
  return 2;
}

int main(int argc, char** argv) {
  std::vector<std::string> p;  // the command words: takeoff | status | procman start cmd:ID ...
  double height_m = 1.0;
  double wait_s = 0.0;
  double seconds = 2.0;
  bool seconds_given = false;
  std::string channel = "COMMAND";
  std::string vehicle_prefix;
  bool vehicle_given = false;
  std::string host;
  double duration_s = 0.0;  // goto: 0 = from the distance
  bool relative = false;    // goto: X Y Z from the set point
  return kestrel::RunProcess(
      "kestrel-cmd", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--height", height_m)->check(kestrel::cli::Positive());
        app.add_option("--wait", wait_s)->check(kestrel::cli::NonNegative());
        app.add_option("--seconds", seconds)
            ->check(kestrel::cli::Positive())
            ->each([&](const std::string&) { seconds_given = true; });
        CLI::Option* channel_option = app.add_option("--channel", channel);
        app.add_option("--vehicle", vehicle_prefix)
            ->each([&](const std::string&) { vehicle_given = true; })
            ->excludes(channel_option);
        app.add_option("--host", host);
        app.add_option("--duration", duration_s)->check(kestrel::cli::Positive());
        app.add_flag("--relative", relative);
        app.add_option("words", p);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        const int code = [&]() -> int {
          using namespace kestrel;
          if (p.empty()) {
            std::fprintf(stderr, "%s", kUsage);
            return 2;
          }
          lcm::LCM lcm(args.lcm_url);
          if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
          WallClock clock;
          const std::string verb = p[0];
          const std::map<std::string, std::pair<int8_t, int8_t>> vehicle = {
              {"idle", {command_t::COMMAND_IDLE, controller_status_t::MODE_IDLE}},
              {"takeoff", {command_t::COMMAND_TAKEOFF, controller_status_t::MODE_TAKEOFF}},
              {"track", {command_t::COMMAND_TRACK, controller_status_t::MODE_TRACK}},
              {"hold", {command_t::COMMAND_HOLD, controller_status_t::MODE_HOLD}},
              {"land", {command_t::COMMAND_LAND, controller_status_t::MODE_LAND}},
              {"estop", {command_t::COMMAND_ESTOP, controller_status_t::MODE_ESTOP}}};
          if (vehicle.count(verb) != 0) {
            // The vehicles to command: one channel, one prefix, or every reporting controller.
            std::vector<std::string> prefixes;
            if (vehicle_given && vehicle_prefix == "all") {
              GuardedSubscriptions subs(lcm);
              subs.Add<controller_status_t>(
                  "(.*)CONTROLLER_STATUS",
                  [&](const std::string& ch, const controller_status_t&) {
                    const std::string prefix = ch.substr(0, ch.size() - 17);
                    if (std::find(prefixes.begin(), prefixes.end(), prefix) == prefixes.end()) {
                      prefixes.push_back(prefix);
                    }
                  },
                  nullptr);
              const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
              while (std::chrono::steady_clock::now() < end && !NodeLoop::signal_received()) {
                lcm.handleTimeout(20);
              }
              if (prefixes.empty()) {
                std::fprintf(stderr, "kestrel-cmd: no controller reported on *CONTROLLER_STATUS\n");
                return 1;
              }
              std::sort(prefixes.begin(), prefixes.end());
            } else {
              prefixes.push_back(vehicle_given ? vehicle_prefix : "");
            }
            command_t cmd{};
            cmd.utime = clock.NowUtime();
            cmd.seq = cmd.utime;  // unique per invocation (the e-stop is sent three times)
            cmd.epoch = NewPublisherEpoch();
            cmd.source = "operator";
            cmd.command = vehicle.at(verb).first;
            cmd.height_m = height_m;
            const int repeats = verb == "estop" ? 3 : 1;
            for (int i = 0; i < repeats; ++i) {
              for (const std::string& prefix : prefixes) {
                lcm.publish(vehicle_given ? prefix + "COMMAND" : channel, &cmd);
              }
            }
            for (const std::string& prefix : prefixes) {
              std::printf("sent %s on %s\n", verb.c_str(),
                          (vehicle_given ? prefix + "COMMAND" : channel).c_str());
            }
            if (wait_s <= 0) return 0;
            const auto end = std::chrono::steady_clock::now() +
                             std::chrono::milliseconds(static_cast<int64_t>(wait_s * 1000));
            std::map<std::string, bool> reached;  // by status channel
            for (const std::string& prefix : prefixes)
              reached[prefix + "CONTROLLER_STATUS"] = false;
            const auto all_reached = [&] {
              for (const auto& [ch, r] : reached) {
                if (!r) return false;
              }
              return true;
            };
            GuardedSubscriptions subs(lcm);
            for (const auto& [status_channel, r] : reached) {
              subs.Add<controller_status_t>(
                  status_channel,
                  [&](const std::string& ch, const controller_status_t& m) {
                    if (m.mode == vehicle.at(verb).second) reached[ch] = true;
                  },
                  nullptr);
            }
            while (!all_reached() && std::chrono::steady_clock::now() < end &&
                   !NodeLoop::signal_received()) {
              lcm.handleTimeout(50);
            }
            for (const auto& [ch, r] : reached) {
              std::printf("%s%s\n", r ? "controller confirmed" : "controller did NOT confirm",
                          prefixes.size() > 1 || vehicle_given ? (" (" + ch + ")").c_str() : "");
            }
            return all_reached() ? 0 : 1;
          }
          if (verb == "goto" && p.size() == 4) {
            return GoTo(lcm, clock, vehicle_prefix, p, relative, duration_s, wait_s);
          }
          if (verb == "status") {
            const auto view = Listen(lcm, seconds);
            std::printf("%s", procman::FormatOperatorView(view, clock.NowUtime()).c_str());
            return 0;
          }
          if (verb == "params" && p.size() <= 2) {
            std::map<std::pair<std::string, int64_t>, params_t> answers;  // (channel, epoch)
            GuardedSubscriptions subs(lcm);
            subs.Add<params_t>(
                "PARAMS_.*",
                [&](const std::string& ch, const params_t& m) {
                  answers[{ch, m.epoch}] = m;
                },
                [](const std::string& ch, const std::string& reason) {
                  std::fprintf(stderr, "kestrel-cmd: %s: dropped a malformed message: %s\n",
                               ch.c_str(), reason.c_str());
                });
            params_request_t request{};
            request.utime = clock.NowUtime();
            request.seq = 0;
            request.epoch = NewPublisherEpoch();
            request.source = "kestrel-cmd";
            request.process = p.size() == 2 ? p[1] : "";
            lcm.publish(kParamsRequestChannel, &request);
            const auto end = std::chrono::steady_clock::now() +
                             std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000));
            while (std::chrono::steady_clock::now() < end && !NodeLoop::signal_received()) {
              lcm.handleTimeout(50);
            }
            int printed = 0;
            for (const auto& [key, m] : answers) {
              if (!request.process.empty() && m.process != request.process) continue;
              std::printf("%s", FormatParams(m).c_str());
              ++printed;
            }
            if (printed == 0) {
              std::fprintf(stderr, "kestrel-cmd: no process answered on PARAMS_* within %g s\n",
                           seconds);
              return 1;
            }
            return 0;
          }
          if (verb == "procman" && p.size() >= 2) {
            return Procman(lcm, clock, p, host, seconds_given ? seconds : -1.0);
          }
          std::fprintf(stderr, "kestrel-cmd: unknown command\n%s", kUsage);
          return 2;
        }();
        // Ctrl-C or SIGTERM cut a wait short: the exit code says so.
        const int signum = kestrel::NodeLoop::received_signal();
        return signum != 0 ? kestrel::NodeLoop::ExitCodeForSignal(signum) : code;
      });
}

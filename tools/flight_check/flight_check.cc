// kestrel-flight-check: listens to a running system for SECONDS and checks that it is flying and
// mapping: every process's heartbeat, message counts, map entropy falling, the vehicle moving,
// no collision. Prints what it saw, with the messages it lost (tools/flight_check/message_loss.h);
// exits 0 when every check passes.
// --until-landed: stop listening as soon as the explorer is done and the controller is idle
// again (the whole exploration), and require that it happened. --csv: MAP_STATUS over time.
// --no-map-loss: fail if any map snapshot chunk or delta was lost on the way to this listener
// (and require two whole snapshots and a delta), docs/design.md §3.3.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <stdexcept>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/lcm_decode.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "kestrel/sim_truth_t.hpp"
#include "tools/flight_check/message_loss.h"

namespace {
const char* const kUsage =
    "usage: kestrel-flight-check URL SECONDS [--until-landed] [--csv FILE] [--hover HEIGHT_M]\n"
    "                            [--no-map-loss]\n"
    "Listens on URL for SECONDS (wall time) and checks that the system flies and maps; exits 0\n"
    "when every check passes. --csv writes MAP_STATUS over time, one flushed line per status.\n"
    "SIGINT or SIGTERM ends the listening early: what was heard is reported and checked, and the\n"
    "exit code is 128 + the signal.\n";

/// Listens for `seconds` and prints what it saw and the checks; returns the exit code.
int CheckFlight(const std::string& url, double seconds, bool until_landed, bool no_map_loss,
                double hover_height_m, const std::string& csv_path) {
  FILE* csv = nullptr;
  if (!csv_path.empty()) {
    csv = std::fopen(csv_path.c_str(), "w");
    if (csv == nullptr) throw std::runtime_error("cannot write " + csv_path);
    std::fprintf(csv, "time_s,entropy_nats,x_m,y_m,z_m,explorer_state,collisions\n");
  }
  int explorer_state = 0;
  int controller_mode = -1;
  bool explorer_done = false;
  double position[3] = {0, 0, 0};
  int64_t first_status_utime = -1;
  lcm::LCM lcm(url);
  if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + url + "'");
  std::map<std::string, int> counts;
  std::set<std::string> processes;
  double first_entropy = -1, last_entropy = -1;
  bool have_start = false;
  double start[3] = {0, 0, 0}, max_distance = 0, max_height = 0;
  int collisions = 0;
  std::set<int> modes;
  kestrel::MessageLoss loss;
  struct Counter {
    std::map<std::string, int>* counts;
    kestrel::MessageLoss* loss;
    void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      ++(*counts)[channel];
      loss->Add(channel, rbuf->data, static_cast<int>(rbuf->data_size));
    }
  } counter{&counts, &loss};
  // Every channel at once (IMU and motor commands at hundreds of Hz): a deep queue, so that a busy
  // moment of this listener is not counted as the system losing messages.
  lcm.subscribe(".*", &Counter::Handle, &counter)->setQueueCapacity(20000);
  kestrel::GuardedSubscriptions subs(lcm);
  subs.Add<kestrel::heartbeat_t>(
      "HEARTBEAT_.*",
      [&](const std::string&, const kestrel::heartbeat_t& m) { processes.insert(m.process); },
      nullptr);
  subs.Add<kestrel::map_status_t>(
      "MAP_STATUS",
      [&](const std::string&, const kestrel::map_status_t& m) {
        if (first_entropy < 0) first_entropy = m.map_entropy_nats;
        last_entropy = m.map_entropy_nats;
        if (first_status_utime < 0) first_status_utime = m.utime;
        if (csv != nullptr) {
          std::fprintf(csv, "%.3f,%.1f,%.3f,%.3f,%.3f,%d,%d\n",
                       static_cast<double>(m.utime - first_status_utime) * 1e-6, m.map_entropy_nats,
                       position[0], position[1], position[2], explorer_state, collisions);
          std::fflush(csv);  // scripts/demo reads the last line while flying
        }
      },
      nullptr);
  subs.Add<kestrel::sim_truth_t>(
      "SIM_TRUTH",
      [&](const std::string&, const kestrel::sim_truth_t& m) {
        if (!have_start) {
          for (int a = 0; a < 3; ++a) start[a] = m.position_m[a];
          have_start = true;
        }
        const double dx = m.position_m[0] - start[0], dy = m.position_m[1] - start[1];
        max_distance = std::max(max_distance, std::sqrt(dx * dx + dy * dy));
        max_height = std::max(max_height, m.position_m[2]);
        collisions = m.collision_count;
        for (int a = 0; a < 3; ++a) position[a] = m.position_m[a];
      },
      nullptr);
  subs.Add<kestrel::controller_status_t>(
      "CONTROLLER_STATUS",
      [&](const std::string&, const kestrel::controller_status_t& m) {
        modes.insert(m.mode);
        controller_mode = m.mode;
      },
      nullptr);
  subs.Add<kestrel::exploration_status_t>(
      "EXPLORATION_STATUS",
      [&](const std::string&, const kestrel::exploration_status_t& m) {
        explorer_state = m.state;
        explorer_done = explorer_done || m.state == kestrel::exploration_status_t::STATE_DONE;
      },
      nullptr);
  const auto end = std::chrono::steady_clock::now() +
                   std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000));
  const auto t_start = std::chrono::steady_clock::now();
  // SIGINT or SIGTERM ends the listening early: what was heard is still reported and checked.
  while (std::chrono::steady_clock::now() < end && !kestrel::NodeLoop::signal_received()) {
    lcm.handleTimeout(50);
    if (until_landed && explorer_done && controller_mode == kestrel::controller_status_t::MODE_IDLE)
      break;
  }
  const double listened_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  if (csv != nullptr) std::fclose(csv);
  loss.Finish();

  for (const auto& [channel, n] : counts) std::printf("%-22s %7d messages\n", channel.c_str(), n);
  std::printf("processes:");
  for (const auto& p : processes) std::printf(" %s", p.c_str());
  std::printf(
      "\nentropy %.0f -> %.0f nats; moved %.2f m, highest %.2f m; collisions %d; listened %.1f s\n",
      first_entropy, last_entropy, max_distance, max_height, collisions, listened_s);
  const kestrel::MessageLoss::Map& map = loss.map();
  std::printf(
      "map loss: %lld lost (snapshot chunks %lld received, %lld lost; snapshots %lld complete, "
      "%lld incomplete, %lld missed; deltas %lld received, %lld gaps)\n",
      static_cast<long long>(loss.map_lost()), static_cast<long long>(map.chunks_received),
      static_cast<long long>(map.chunks_lost), static_cast<long long>(map.snapshots_complete),
      static_cast<long long>(map.snapshots_incomplete),
      static_cast<long long>(map.snapshots_missed), static_cast<long long>(map.deltas_received),
      static_cast<long long>(map.delta_gaps));
  std::printf("largest map messages: chunk %lld bytes, delta %lld bytes\n",
              static_cast<long long>(map.largest_chunk_bytes),
              static_cast<long long>(map.largest_delta_bytes));
  std::printf("sequence gaps: %lld lost", static_cast<long long>(loss.streams_lost()));
  for (const auto& [channel, s] : loss.streams()) {
    if (s.lost > 0)
      std::printf(", %s %lld of %lld", channel.c_str(), static_cast<long long>(s.lost),
                  static_cast<long long>(s.lost + s.received));
  }
  std::printf("\n");
  int failures = 0;
  auto check = [&](bool ok, const char* what) {
    if (!ok) {
      std::printf("FAIL: %s\n", what);
      ++failures;
    }
  };
  if (hover_height_m > 0) {
    for (const char* p : {"kestrel-sim", "kestrel-controller"}) {
      check(processes.count(p) == 1, (std::string("no heartbeat from ") + p).c_str());
    }
    check(counts["MOTOR_COMMAND"] > 50 * listened_s, "too few MOTOR_COMMAND");
    check(std::abs(position[2] - hover_height_m) < 0.15, "not hovering at the commanded height");
    check(max_distance < 0.3, "drifted more than 0.3 m while hovering");
    check(collisions == 0, "collision");
  } else {
    for (const char* p :
         {"kestrel-sim", "kestrel-controller", "kestrel-mapper", "kestrel-explorer"}) {
      check(processes.count(p) == 1, (std::string("no heartbeat from ") + p).c_str());
    }
    // Generous bounds: the simulator runs at its speed factor on a loaded machine.
    check(counts["POSE_VICON"] > 20 * listened_s, "too few POSE_VICON");
    check(counts["DEPTH_XTION"] > 2 * listened_s, "too few DEPTH_XTION");
    check(counts["SCAN_HOKUYO"] > 2 * listened_s, "too few SCAN_HOKUYO");
    check(counts["MOTOR_COMMAND"] > 50 * listened_s, "too few MOTOR_COMMAND");
    check(counts["TRAJECTORY"] >= 2, "the explorer sent fewer than 2 trajectories");
    check(first_entropy > 0 && last_entropy < 0.9 * first_entropy,
          "map entropy did not fall by 10%");
    check(max_height > 0.5, "the vehicle did not take off");
    check(max_distance > 0.5, "the vehicle did not move 0.5 m");
    check(modes.count(kestrel::controller_status_t::MODE_TRACK) == 1,
          "the controller never tracked");
    check(collisions == 0, "collision");
    if (until_landed) {
      check(explorer_done, "the explorer did not finish");
      check(controller_mode == kestrel::controller_status_t::MODE_IDLE, "the vehicle did not land");
    }
  }
  if (no_map_loss) {
    check(loss.map_lost() == 0, "map messages lost");
    check(map.snapshots_complete >= 2 && map.deltas_received >= 1,
          "fewer than two whole map snapshots or no delta received");
  }
  std::printf("%s\n", failures == 0 ? "PASS" : "FAIL");
  if (const int signum = kestrel::NodeLoop::received_signal()) {
    std::printf(
        "interrupted by signal %d after %.1f s of listening: the checks are of what was "
        "heard\n",
        signum, listened_s);
    return kestrel::NodeLoop::ExitCodeForSignal(signum);
  }
  return failures == 0 ? 0 : 1;
}
}  // namespace

int main(int argc, char** argv) {
  std::string url;
  double seconds = 0.0;
  bool until_landed = false;
  bool no_map_loss = false;
  double hover_height_m = -1.0;  // --hover H: only the simulator and the controller, hovering at H
  std::string csv_path;
  return kestrel::RunProcess(
      "kestrel-flight-check", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("url", url)->required();
        app.add_option("seconds", seconds)->required()->check(kestrel::cli::Positive());
        app.add_flag("--until-landed", until_landed);
        app.add_flag("--no-map-loss", no_map_loss);
        app.add_option("--hover", hover_height_m)->check(kestrel::cli::Positive());
        app.add_option("--csv", csv_path);
      },
      [&](const kestrel::ProcessArgs&, kestrel::ConfigNode&) {
        return CheckFlight(url, seconds, until_landed, no_map_loss, hover_height_m, csv_path);
      });
}

// libFuzzer target: every Kestrel LCM type, and libbot2's bot-procman types the runner takes from
// the network, through the guarded decoder (common/lcm_decode.h), then what consumes the decoded
// message: the payload codecs (lcmtypes/message_codecs.h), the trajectory conversion, a map
// replica, the viewer's scene, and a sheriff's orders as the runner reads them (every exec
// string split and expanded, common/procman/exec_line.h). The first input byte picks the
// type (docs/design.md §7.7); the rest is the message's bytes. Properties, beyond no crash and no
// sanitizer report: a message that decodes re-encodes to exactly its bytes; depth pixels and
// snapshot cells that decode re-encode (raw) and decode to the same values; a trajectory that
// converts converts back to the same trajectory.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "bot_procman/discovery_t.hpp"
#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "bot_procman/printf_t.hpp"
#include "common/lcm_decode.h"
#include "common/procman/bot_procman.h"
#include "common/procman/exec_line.h"
#include "common/trajectory_message.h"
#include "kestrel/candidate_t.hpp"
#include "kestrel/command_t.hpp"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/depth_image_t.hpp"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/heartbeat_t.hpp"
#include "kestrel/imu_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/map_decision_t.hpp"
#include "kestrel/map_decisions_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "kestrel/motor_command_t.hpp"
#include "kestrel/named_value_t.hpp"
#include "kestrel/param_t.hpp"
#include "kestrel/params_request_t.hpp"
#include "kestrel/params_t.hpp"
#include "kestrel/planar_scan_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/procman_command_t.hpp"
#include "kestrel/procman_order_t.hpp"
#include "kestrel/procman_status_t.hpp"
#include "kestrel/sim_truth_t.hpp"
#include "kestrel/trajectory_t.hpp"
#include "lcmtypes/message_codecs.h"
#include "mapping/map_decisions.h"
#include "mapping/map_replica.h"
#include "viewer/bridge/viewer_scene.h"

namespace {

void Require(bool condition) {
  if (!condition) std::abort();
}

// What follows a successful decode, per type (nothing by default).
template <typename T>
void Consume(const T& /*msg*/) {}

void Consume(const kestrel::depth_image_t& msg) {
  std::vector<uint16_t> counts;
  if (!kestrel::DecodeDepthPixels(msg, &counts).empty()) {
    Require(counts.empty());
    return;
  }
  kestrel::depth_image_t again = msg;
  kestrel::EncodeDepthPixels(counts, kestrel::depth_image_t::ENCODING_RAW_U16, 0, &again);
  std::vector<uint16_t> counts_again;
  Require(kestrel::DecodeDepthPixels(again, &counts_again).empty() && counts_again == counts);
}

void Consume(const kestrel::map3d_chunk_t& msg) {
  std::vector<float> cells;
  if (kestrel::DecodeMapChunkCells(msg, &cells).empty()) {
    kestrel::map3d_chunk_t again = msg;
    kestrel::EncodeMapChunkCells(cells, kestrel::map3d_chunk_t::ENCODING_FLOAT32, 0, &again);
    std::vector<float> cells_again;
    Require(kestrel::DecodeMapChunkCells(again, &cells_again).empty());
    // Bit for bit (NaN payloads included); a chunk of no block has no cell to compare.
    Require(cells_again.size() == cells.size() &&
            (cells.empty() ||
             std::memcmp(cells.data(), cells_again.data(), cells.size() * sizeof(float)) == 0));
  }
  std::string error;
  // The replica's lattice is the seeds' (origin 0, 7.5 cm); other chunks are refused by it.
  kestrel::MapReplica replica(Eigen::Vector3d::Zero(), 0.075, Eigen::Vector3i(40, 40, 20), 0.1);
  (void)replica.Apply(msg, &error);
  kestrel::ViewerScene scene{kestrel::ViewerSceneConfig{}};
  (void)scene.OnMapChunk(msg, &error);
  (void)scene.TakeUpdateFrames();
  (void)scene.SnapshotFrames();
}

void Consume(const kestrel::map3d_delta_t& msg) {
  (void)kestrel::CheckMapDelta(msg);
  std::string error;
  kestrel::MapReplica replica(Eigen::Vector3d::Zero(), 0.075, Eigen::Vector3i(40, 40, 20), 0.1);
  (void)replica.Apply(msg, &error);
  kestrel::ViewerScene scene{kestrel::ViewerSceneConfig{}};
  (void)scene.OnMapDelta(msg, &error);
  (void)scene.TakeUpdateFrames();
}

void Consume(const kestrel::trajectory_t& msg) {
  std::string error;
  const auto trajectory = kestrel::FromMessage(msg, &error);
  kestrel::ViewerScene scene{kestrel::ViewerSceneConfig{}};
  (void)scene.OnTrajectory(msg, &error);
  (void)scene.TakeUpdateFrames();
  if (!trajectory) return;
  const kestrel::trajectory_t again =
      kestrel::ToMessage(*trajectory, msg.utime, msg.seq, msg.epoch);
  Require(again.num_segments == msg.num_segments && again.num_coeffs == msg.num_coeffs);
  Require(again.durations_s == msg.durations_s && again.coeffs_x == msg.coeffs_x &&
          again.coeffs_y == msg.coeffs_y && again.coeffs_z == msg.coeffs_z &&
          again.coeffs_yaw == msg.coeffs_yaw);
  // Seconds in a double hold every microsecond below 2^50 us (35 years from 1970).
  if (msg.start_utime > -(int64_t{1} << 50) && msg.start_utime < (int64_t{1} << 50)) {
    Require(again.start_utime == msg.start_utime);
  }
}

void Consume(const kestrel::grid_map_t& msg) {
  std::string error;
  kestrel::ViewerScene scene{kestrel::ViewerSceneConfig{}};
  (void)scene.OnGridMap("MAP2D_FUZZ", msg, &error);
  (void)scene.TakeUpdateFrames();
}

void Consume(const kestrel::pose_t& msg) {
  kestrel::ViewerScene scene{kestrel::ViewerSceneConfig{}};
  scene.OnPose(msg);
  scene.OnPose(msg);
  (void)scene.TakeUpdateFrames();
}

void Consume(const kestrel::exploration_status_t& msg) {
  kestrel::ViewerScene scene{kestrel::ViewerSceneConfig{}};
  scene.OnExploration(msg);
  (void)scene.TakeUpdateFrames();
}

void Consume(const kestrel::map_status_t& msg) {
  kestrel::ViewerScene scene{kestrel::ViewerSceneConfig{}};
  scene.OnMapStatus(msg);
  (void)scene.TakeUpdateFrames();
}

// The mapper's decisions as a replay gathers them (docs/design.md §3.6): a message accepted
// alone, numbered from 0 and resuming nothing, is the whole map of its life, in its order; one
// numbered later, or resuming a life, leaves a gap that MapOf names.
void Consume(const kestrel::map_decisions_t& msg) {
  kestrel::DecisionHistory history;
  std::string why;
  if (!history.Add(msg, &why)) {
    Require(!why.empty());
    return;
  }
  const std::vector<kestrel::map_decision_t> map = history.MapOf(msg.epoch, &why);
  if (msg.first_index == 0 && msg.num_lives == 0) {
    Require(map.size() == msg.decisions.size());
    for (size_t i = 0; i < map.size(); ++i) {
      Require(kestrel::SameDecision(map[i], msg.decisions[i]));
    }
  } else if (msg.num_decisions > 0 || msg.num_lives > 0) {
    // Decisions 0 .. first_index - 1, or a resumed life's, were never heard.
    Require(map.empty() && !why.empty());
  } else {
    // A message with no decision, whatever its first index, adds nothing to an empty history.
    Require(map.empty() && why.empty());
  }
}

// A sheriff's exec strings as the runner reads them. With every variable unset, splitting and
// expansion only remove characters: every character of a word or setting is in the string.
void Consume(const bot_procman::orders2_t& msg) {
  const kestrel::procman::VariableLookup unset =
      [](const std::string&) -> std::optional<std::string> { return std::nullopt; };
  const kestrel::procman::VariableLookup named =
      [](const std::string& name) -> std::optional<std::string> { return "<" + name + ">"; };
  for (const bot_procman::sheriff_cmd2_t& c : msg.cmds) {
    const std::string& exec = c.cmd.exec_str;
    const kestrel::procman::ExecLine line = kestrel::procman::ParseExecLine(exec, unset);
    const auto from_exec = [&](const std::string& text) {
      for (const char ch : text) Require(exec.find(ch) != std::string::npos);
    };
    for (const auto& [name, value] : line.environment) {
      from_exec(name);
      from_exec(value);
    }
    for (const std::string& word : line.argv) from_exec(word);
    (void)kestrel::procman::ParseExecLine(exec, named);
    (void)kestrel::procman::DecideOrder(true, 1, c);
    (void)kestrel::procman::DecideOrder(false, 0, c);
  }
}

template <typename T>
void Fuzz(const uint8_t* data, size_t size) {
  T msg;
  std::string error;
  if (!kestrel::GuardedDecode(data, size, &msg, &error)) {
    Require(!error.empty());
    return;
  }
  // LCM's encoding is canonical: what decoded must encode to the same bytes.
  const int encoded_size = msg.getEncodedSize();
  Require(encoded_size == static_cast<int>(size));
  std::vector<uint8_t> again(size);
  Require(msg.encode(again.data(), 0, encoded_size) == encoded_size);
  Require(std::memcmp(again.data(), data, size) == 0);
  Consume(msg);
}

using FuzzFn = void (*)(const uint8_t*, size_t);
// Every type of lcmtypes/CMakeLists.txt, nested-only ones included; fuzz_seeds.cc writes the
// seeds in this order.
constexpr FuzzFn kTypes[] = {
    Fuzz<kestrel::pose_t>,
    Fuzz<kestrel::imu_t>,
    Fuzz<kestrel::depth_image_t>,
    Fuzz<kestrel::planar_scan_t>,
    Fuzz<kestrel::map3d_chunk_t>,
    Fuzz<kestrel::map3d_delta_t>,
    Fuzz<kestrel::grid_map_t>,
    Fuzz<kestrel::exploration_status_t>,
    Fuzz<kestrel::trajectory_t>,
    Fuzz<kestrel::motor_command_t>,
    Fuzz<kestrel::controller_status_t>,
    Fuzz<kestrel::command_t>,
    Fuzz<kestrel::sim_truth_t>,
    Fuzz<kestrel::heartbeat_t>,
    Fuzz<kestrel::map_status_t>,
    Fuzz<kestrel::procman_status_t>,
    Fuzz<kestrel::procman_order_t>,
    Fuzz<kestrel::candidate_t>,
    Fuzz<kestrel::named_value_t>,
    Fuzz<kestrel::procman_command_t>,
    Fuzz<kestrel::param_t>,
    Fuzz<kestrel::params_t>,
    Fuzz<kestrel::params_request_t>,
    Fuzz<kestrel::map_decisions_t>,
    Fuzz<kestrel::map_decision_t>,
    Fuzz<bot_procman::info2_t>,
    Fuzz<bot_procman::orders2_t>,
    Fuzz<bot_procman::printf_t>,
    Fuzz<bot_procman::discovery_t>,
};
static_assert(sizeof(kTypes) / sizeof(kTypes[0]) == 29,
              "one entry per lcmtypes/*.lcm, and the top-level bot_procman types");

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  kTypes[data[0] % (sizeof(kTypes) / sizeof(kTypes[0]))](data + 1, size - 1);
  return 0;
}

#include "tools/fault/malformed.h"

#include <algorithm>
#include <random>
#include <utility>

#include "bot_procman/command2_t.hpp"
#include "bot_procman/deputy_cmd2_t.hpp"
#include "bot_procman/discovery_t.hpp"
#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "bot_procman/printf_t.hpp"
#include "bot_procman/sheriff_cmd2_t.hpp"
#include "common/fnv1a.h"
#include "common/lcm_decode.h"
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

namespace kestrel {
namespace {

template <typename... Types>
std::vector<std::pair<std::string, int64_t>> TypeTable() {
  return {{Types::getTypeName(), Types::getHash()}...};
}

const std::vector<std::pair<std::string, int64_t>>& Types() {
  static const auto table =
      TypeTable<candidate_t, command_t, controller_status_t, depth_image_t, exploration_status_t,
                grid_map_t, heartbeat_t, imu_t, map3d_chunk_t, map3d_delta_t, map_decision_t,
                map_decisions_t, map_status_t, motor_command_t, named_value_t, param_t,
                params_request_t, params_t, planar_scan_t, pose_t, procman_command_t,
                procman_order_t, procman_status_t, sim_truth_t, trajectory_t,
                bot_procman::command2_t, bot_procman::deputy_cmd2_t, bot_procman::discovery_t,
                bot_procman::info2_t, bot_procman::orders2_t, bot_procman::printf_t,
                bot_procman::sheriff_cmd2_t>();
  return table;
}

// Uniform in [0, n) for n >= 1 (modulo: the tiny bias does not matter here, the sequence is
// fixed by the engine alone).
size_t Below(std::mt19937_64* rng, size_t n) { return static_cast<size_t>((*rng)() % n); }

std::vector<uint8_t> Garbage(std::mt19937_64* rng) {
  std::vector<uint8_t> bytes(8 + Below(rng, 249));
  for (uint8_t& b : bytes) b = static_cast<uint8_t>((*rng)());
  return bytes;
}

}  // namespace

const char* MalformedKindName(MalformedKind kind) {
  switch (kind) {
    case MalformedKind::kGarbage:
      return "garbage";
    case MalformedKind::kTruncated:
      return "truncated";
    case MalformedKind::kBadFingerprint:
      return "bad_fingerprint";
    case MalformedKind::kHugeLength:
      return "huge_length";
  }
  return "?";
}

std::string KnownTypeOf(const std::vector<uint8_t>& bytes) {
  if (bytes.size() < 8) return "";
  uint64_t hash = 0;
  for (int b = 0; b < 8; ++b) hash = (hash << 8) | bytes[static_cast<size_t>(b)];
  for (const auto& [name, h] : Types()) {
    if (h == static_cast<int64_t>(hash)) return name;
  }
  return "";
}

int64_t FingerprintOf(const std::string& type_name) {
  for (const auto& [name, h] : Types()) {
    if (name == type_name) return h;
  }
  return 0;
}

std::vector<MalformedMessage> MakeMalformedBurst(const std::string& channel,
                                                 const std::vector<uint8_t>& sample, int count,
                                                 uint64_t seed) {
  std::mt19937_64 rng(seed ^ Fnv1a(channel));
  const std::string type = KnownTypeOf(sample);
  std::vector<LcmLengthField> lengths;
  if (!type.empty()) {
    lengths = LcmLengthFields(type.c_str(), FingerprintOf(type), sample.data(), sample.size());
  }
  // The first length field of 4 or 8 bytes: its largest value is past the end of any message.
  const auto huge = std::find_if(lengths.begin(), lengths.end(),
                                 [](const LcmLengthField& f) { return f.width >= 4; });
  std::vector<MalformedMessage> out;
  for (int i = 0; i < count; ++i) {
    MalformedMessage m;
    m.kind = static_cast<MalformedKind>(i % 4);
    if (m.kind == MalformedKind::kTruncated && sample.size() > 8) {
      m.bytes.assign(sample.begin(),
                     sample.begin() + static_cast<std::ptrdiff_t>(Below(&rng, sample.size())));
    } else if (m.kind == MalformedKind::kBadFingerprint && sample.size() > 8) {
      m.bytes = sample;
      uint64_t flip = 0;
      while (flip == 0) flip = rng();
      for (int b = 0; b < 8; ++b)
        m.bytes[static_cast<size_t>(b)] ^= static_cast<uint8_t>(flip >> (8 * b));
    } else if (m.kind == MalformedKind::kHugeLength && huge != lengths.end()) {
      m.bytes = sample;
      const LcmLengthField& f = *huge;
      // The largest positive value of the field's width, big-endian: 0x7f then 0xff...
      for (int b = 0; b < f.width; ++b)
        m.bytes[f.offset + static_cast<size_t>(b)] = b == 0 ? 0x7f : 0xff;
    } else {
      m.kind = MalformedKind::kGarbage;
      m.bytes = Garbage(&rng);
    }
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace kestrel

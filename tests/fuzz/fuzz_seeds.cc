// Writes the seed inputs of the libFuzzer targets (tests/fuzz/*_fuzz.cc) into a folder, one
// subfolder per target: every LCM type's sample messages (with the type's selector byte, and the
// compressed payload encodings), small saved maps (dense and growing, exact and log-odds, a
// checkpoint with a run id and a version 1 file), WebSocket sessions, and the shipped worlds
// (config/worlds, each followed by the OBJ mesh) and process sheets (scripts/sheets).
// Usage: fuzz_seeds OUT_DIR SOURCE_DIR
#include <dirent.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "bot_procman/discovery_t.hpp"
#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "bot_procman/printf_t.hpp"
#include "kestrel/param_t.hpp"
#include "kestrel/params_request_t.hpp"
#include "kestrel/params_t.hpp"
#include "kestrel/procman_command_t.hpp"
#include "lcmtypes/message_codecs.h"
#include "mapping/map_file.h"
#include "mapping/scan_integrator.h"
#include "tests/lcmtypes/sample_messages.h"

namespace {

using namespace kestrel;           // NOLINT(google-build-using-namespace): a test tool
using namespace kestrel::testing;  // NOLINT(google-build-using-namespace)

std::string g_out;

void Write(const std::string& dir, const std::string& name, const std::string& bytes) {
  ::mkdir((g_out + "/" + dir).c_str(), 0755);
  std::ofstream out(g_out + "/" + dir + "/" + name, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Must follow kTypes in lcm_fuzz.cc.
template <typename T>
void WriteLcm(uint8_t selector, const T& msg, const std::string& name) {
  const std::vector<uint8_t> bytes = Encode(msg);
  Write("lcm", name,
        std::string(1, static_cast<char>(selector)) + std::string(bytes.begin(), bytes.end()));
}

template <typename T>
void WriteSamples(uint8_t selector) {
  for (uint64_t k = 0; k < 2; ++k) {
    WriteLcm(selector, MakeSample<T>(k), std::string(T::getTypeName()) + "-" + std::to_string(k));
  }
}

void WriteLcmSeeds() {
  WriteSamples<pose_t>(0);
  WriteSamples<imu_t>(1);
  WriteSamples<depth_image_t>(2);
  WriteSamples<planar_scan_t>(3);
  WriteSamples<map3d_chunk_t>(4);
  WriteSamples<map3d_delta_t>(5);
  WriteSamples<grid_map_t>(6);
  WriteSamples<exploration_status_t>(7);
  WriteSamples<trajectory_t>(8);
  WriteSamples<motor_command_t>(9);
  WriteSamples<controller_status_t>(10);
  WriteSamples<command_t>(11);
  WriteSamples<sim_truth_t>(12);
  WriteSamples<heartbeat_t>(13);
  WriteSamples<map_status_t>(14);
  WriteSamples<procman_status_t>(15);
  WriteSamples<procman_order_t>(16);
  WriteSamples<candidate_t>(17);
  WriteSamples<named_value_t>(18);
  WriteLcm(19, procman_command_t{}, "procman_command_t-0");
  WriteSamples<param_t>(20);
  WriteSamples<params_t>(21);
  WriteSamples<params_request_t>(22);
  WriteSamples<map_decisions_t>(23);
  map_decisions_t no_decision{};  // later in its life, and nothing in it: a gap-free empty map
  no_decision.epoch = 5;
  no_decision.first_index = 3;
  WriteLcm(23, no_decision, "map_decisions_t-none-from-3");
  WriteSamples<map_decision_t>(24);
  // libbot2's bot-procman messages, as a sheriff and a deputy send them.
  bot_procman::info2_t info{};
  info.host = "jetson";
  info.ncmds = 1;
  info.cmds.resize(1);
  info.cmds[0] = bot_procman::deputy_cmd2_t{};
  info.cmds[0].cmd.exec_str = "$KESTREL_BIN/kestrel-hokuyo --config config/drivers/hokuyo.yaml";
  info.cmds[0].cmd.command_name = "hokuyo";
  info.cmds[0].sheriff_id = 7;
  WriteLcm(25, info, "info2_t-0");
  bot_procman::orders2_t orders{};
  orders.host = "jetson";
  orders.sheriff_name = "base:1:2";
  orders.ncmds = 1;
  orders.cmds.resize(1);
  orders.cmds[0] = bot_procman::sheriff_cmd2_t{};
  orders.cmds[0].cmd.exec_str = "A=1 prog 'a b' \"$X\" ${Y} $Z1 ${";
  orders.cmds[0].desired_runid = 2;
  orders.cmds[0].sheriff_id = 7;
  WriteLcm(26, orders, "orders2_t-0");
  bot_procman::printf_t text{};
  text.deputy_name = "jetson";
  text.text = "hello\n";
  WriteLcm(27, text, "printf_t-0");
  bot_procman::discovery_t discovery{};
  discovery.host = "jetson";
  WriteLcm(28, discovery, "discovery_t-0");

  // The compressed payloads, and values a consumer accepts (probabilities in [0, 1]).
  depth_image_t depth = MakeSample<depth_image_t>(0);
  std::vector<uint16_t> counts(static_cast<size_t>(depth.width * depth.height));
  for (size_t i = 0; i < counts.size(); ++i) counts[i] = static_cast<uint16_t>(500 + 7 * i);
  EncodeDepthPixels(counts, depth_image_t::ENCODING_ZLIB_U16, 6, &depth);
  WriteLcm(2, depth, "depth_image_t-zlib");
  map3d_chunk_t chunk = MakeSample<map3d_chunk_t>(0);
  chunk.origin_m[0] = chunk.origin_m[1] = chunk.origin_m[2] = 0.0;
  chunk.block_index = {{0, 0, 0}, {1, 0, 0}, {0, 1, 1}};
  std::vector<float> cells(3 * 512);
  for (size_t i = 0; i < cells.size(); ++i) cells[i] = static_cast<float>(i % 101) / 100.0f;
  for (const int8_t encoding :
       {map3d_chunk_t::ENCODING_FLOAT32, map3d_chunk_t::ENCODING_ZLIB_FLOAT32,
        map3d_chunk_t::ENCODING_U16_ZLIB}) {
    EncodeMapChunkCells(cells, encoding, 6, &chunk);
    WriteLcm(4, chunk, "map3d_chunk_t-encoding-" + std::to_string(encoding));
  }
  map3d_chunk_t no_block = chunk;  // a chunk of no block: no cell
  no_block.num_blocks = 0;
  no_block.block_index.clear();
  EncodeMapChunkCells({}, map3d_chunk_t::ENCODING_FLOAT32, 0, &no_block);
  WriteLcm(4, no_block, "map3d_chunk_t-no-block");
  map3d_delta_t delta = MakeSample<map3d_delta_t>(0);
  delta.origin_m[0] = delta.origin_m[1] = delta.origin_m[2] = 0.0;
  for (size_t i = 0; i < delta.cells.size(); ++i) {
    delta.cells[i] = {static_cast<int32_t>(i % 40), static_cast<int32_t>(i / 2), 3};
    delta.probabilities[i] = static_cast<float>(i) / 40.0f;
  }
  WriteLcm(5, delta, "map3d_delta_t-valid");
  MapDeltaCells packed;
  for (size_t i = 0; i < delta.cells.size(); ++i) {
    packed.cells.push_back({delta.cells[i][0], delta.cells[i][1], delta.cells[i][2]});
    packed.probabilities.push_back(delta.probabilities[i]);
  }
  EncodeMapDeltaCells(packed, map3d_delta_t::ENCODING_ZLIB_CELLS, 1, &delta);
  WriteLcm(5, delta, "map3d_delta_t-packed");
}

template <class Map>
void FillRays(Map* map) {
  const SensorModel xtion(SensorModelConfig::Xtion());
  ScanIntegrator integrator(map);
  for (int i = 0; i < 200; ++i) {
    const double a = 0.0314 * i;
    integrator.IntegrateRay(Eigen::Vector3d(0.1, 0.2, 0.7),
                            Eigen::Vector3d(std::cos(a), std::sin(a), 0.1).normalized(),
                            0.8 + 0.01 * i, xtion);
  }
}

// The file as a seed twice: whole (flag 0), and without its CRC (flag 1: the target appends it).
void WriteMap(const std::string& name, const std::string& bytes) {
  Write("map", name, std::string(1, '\0') + bytes);
  Write("map", name + "-nocrc", std::string(1, '\1') + bytes.substr(0, bytes.size() - 4));
}

void WriteMapSeeds() {
  MapLimits small;
  small.min_m = Eigen::Vector3d(-1.0, -1.0, 0.0);
  small.max_m = Eigen::Vector3d(1.0, 1.0, 1.0);
  small.resolution_m = 0.1;
  const StreamSequences seqs{{"DEPTH_XTION", {{0x7123456789abcdef, 1234}, {42, 7}}},
                             {"POSE_VICON", {{9, 99}}}};
  auto dense = MakeExactDenseMap(small, OccupancyLimits{}, 5.0);
  FillRays(dense.get());
  WriteMap("dense-exact-checkpoint", EncodeMap(*dense, seqs, "20240611T093012Z-5f3a9c01"));
  auto log_odds = MakeLogOddsDenseMap(small, LogOddsConfig{}, 5.0);
  FillRays(log_odds.get());
  WriteMap("dense-log-odds", EncodeMap(*log_odds, {}));
  auto growing = MakeExactGrowingMap(small, OccupancyLimits{}, 5.0);
  FillRays(growing.get());
  WriteMap("growing-exact", EncodeMap(*growing, seqs));
  // Version 1: no run id; with no streams the rest is the same as version 2.
  auto empty = MakeExactDenseMap(small, OccupancyLimits{}, 5.0);
  std::string v1 = EncodeMap(*empty, {});
  v1 = v1.substr(0, v1.size() - 4);
  const uint32_t version = 1;
  std::memcpy(&v1[8], &version, 4);
  const size_t run_id_at = 8 + 4 + 4 + 4 + 8 * 13;  // magic to updater parameters
  v1.erase(run_id_at, 4);
  Write("map", "dense-v1-nocrc", std::string(1, '\1') + v1);
}

std::string Frame(uint8_t opcode, const std::string& payload) {
  std::string f;
  f += static_cast<char>(0x80 | opcode);
  f += static_cast<char>(0x80 | payload.size());  // masked, payload < 126 bytes
  const char mask[4] = {0x11, 0x22, 0x33, 0x44};
  f.append(mask, 4);
  for (size_t i = 0; i < payload.size(); ++i) f += static_cast<char>(payload[i] ^ mask[i % 4]);
  return f;
}

void WriteWebSocketSeeds() {
  const std::string upgrade =
      "GET /ws HTTP/1.1\r\nHost: 127.0.0.1:8740\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
      "Origin: http://127.0.0.1:8740\r\n\r\n";
  Write("ws", "session",
        std::string(1, '\x7f') + upgrade + Frame(0x1, "hello") +
            Frame(0x2, std::string("\x01\x02\x03", 3)) + Frame(0x9, "ping") +
            Frame(0x8, "\x03\xe8"));
  Write("ws", "session-small-pieces", std::string(1, '\x02') + upgrade + Frame(0x1, "{}"));
  Write("ws", "foreign-origin",
        std::string(1, '\x7f') +
            "GET / HTTP/1.1\r\nHost: evil.example\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
            "Origin: http://evil.example\r\n\r\n");
  Write("ws", "http-get",
        std::string(1, '\x7f') + "GET /viewer.js?v=1 HTTP/1.1\r\nHost: localhost:8740\r\n\r\n");
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Every file of `dir` whose name ends in `suffix`, as seeds of `target` (`tail` appended).
void CopySeeds(const std::string& dir, const std::string& suffix, const std::string& target,
               const std::string& tail) {
  DIR* d = ::opendir(dir.c_str());
  if (d == nullptr) return;
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (name.size() > suffix.size() &&
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      Write(target, name, ReadAll(dir + "/" + name) + tail);
    }
  }
  ::closedir(d);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: fuzz_seeds OUT_DIR SOURCE_DIR\n";
    return 2;
  }
  g_out = argv[1];
  ::mkdir(g_out.c_str(), 0755);
  WriteLcmSeeds();
  WriteMapSeeds();
  WriteWebSocketSeeds();
  const std::string source = argv[2];
  CopySeeds(source + "/config/worlds", ".yaml", "world",
            "\n#--obj--\n" + ReadAll(source + "/config/worlds/meshes/pyramid.obj"));
  CopySeeds(source + "/scripts/sheets", ".procman", "sheet", "");
  return 0;
}

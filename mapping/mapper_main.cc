// kestrel-mapper: fuses depth images and planar scans into the exact 3D occupancy map.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/identity.h"
#include "common/log.h"
#include "common/log_tail.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/sim_truth_clock.h"
#include "mapping/mapper_node.h"

namespace {
const char* const kUsage =
    "usage: kestrel-mapper [--config config/mapper.yaml] [--set key=value]... [--lcm-url URL]\n"
    "                      [--save FILE] [--export-octomap FILE.bt|.ot] [--export-ply FILE]\n"
    "                      [--replay LOG]\n"
    "Subscribes to the sensors and poses of its configuration, publishes MAP3D snapshots,\n"
    "MAP3D_DELTA, MAP_STATUS and a heartbeat, checkpoints the map, and on exit (SIGINT/SIGTERM)\n"
    "applies what it can, saves the checkpoint and the files asked for. A mapper resumed from its\n"
    "checkpoint first catches up from catch_up_log. --replay LOG feeds a recorded log into a "
    "fresh\n"
    "map instead, with no live input and no checkpoint, then saves the files asked for; both "
    "print\n"
    "the map hash at the end.\n";

std::string HashText(uint64_t hash) {
  char text[32];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

// Catches up from the run's log (docs/design.md §3.6): the live input is held while the log is
// read from its start, until the log has reached the held messages and its end (or
// catch_up_wait_s has passed with the log's end read but no overlap).
void CatchUp(lcm::LCM& lcm, kestrel::MapperNode& mapper, const kestrel::MapperConfig& config) {
  using kestrel::Log;
  using kestrel::LogLevel;
  std::unique_ptr<kestrel::LogTail> log;
  try {
    log = std::make_unique<kestrel::LogTail>(config.catch_up_log);
  } catch (const std::exception& e) {
    Log(LogLevel::kWarning, std::string("no catch-up: ") + e.what() +
                                "; what came while the mapper was down is not in the map");
    return;
  }
  mapper.BeginCatchUp();
  const auto start = std::chrono::steady_clock::now();
  auto end_read_since = std::chrono::steady_clock::time_point::max();
  while (!kestrel::NodeLoop::signal_received()) {
    bool at_end = false;
    for (int n = 0; n < 100; ++n) {
      const std::optional<kestrel::LoggedEvent> e = log->Next();
      if (!e) {
        at_end = true;
        break;
      }
      mapper.FeedCatchUp(e->channel, e->data.data(), e->data.size());
    }
    while (lcm.handleTimeout(0) > 0) {
    }
    mapper.PublishDue();
    if (!at_end) continue;
    if (mapper.catch_up_overlaps()) break;
    const auto now = std::chrono::steady_clock::now();
    end_read_since = std::min(end_read_since, now);
    if (now - end_read_since > std::chrono::duration<double>(config.catch_up_wait_s)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const kestrel::MapperNode::CatchUpResult r = mapper.EndCatchUp();
  const double took_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string what = "caught up from " + config.catch_up_log + ": " + std::to_string(r.fed) +
                           " logged messages read, " + std::to_string(r.held) +
                           " live messages held meanwhile (" + std::to_string(r.repeated) +
                           " of them also in the log), " + std::to_string(took_s) + " s";
  if (r.overlapped) {
    Log(LogLevel::kInfo, what);
  } else {
    Log(LogLevel::kWarning, what + "; the log never reached the live input within " +
                                std::to_string(config.catch_up_wait_s) +
                                " s: messages between its end and the first live one may be "
                                "missing");
  }
}

// --replay: the log into a fresh map, in log order, as if received live by a mapper that kept up.
int Replay(const std::string& path, kestrel::MapperConfig config, const std::string& save_path,
           const std::string& octomap_path, const std::string& ply_path) {
  config.checkpoint_path.clear();  // never resume or overwrite a live mapper's checkpoint
  config.catch_up_log.clear();
  lcm::LCM lcm("memq://");
  kestrel::SimClock clock(0);
  kestrel::MapperNode mapper(lcm, config, clock);
  kestrel::LogTail log(path);
  while (const std::optional<kestrel::LoggedEvent> e = log.Next()) {
    if (e->timestamp > clock.NowUtime()) clock.SetUtime(e->timestamp);
    mapper.HandleRecorded(e->channel, e->data.data(), e->data.size());
  }
  mapper.ApplyRemaining();
  if (!save_path.empty()) mapper.SaveMapFile(save_path);
  if (!octomap_path.empty()) mapper.ExportOctoMapFile(octomap_path);
  if (!ply_path.empty()) mapper.ExportPlyFile(ply_path);
  std::string skipped;
  for (const auto& [reason, n] : mapper.skipped().counts()) {
    skipped += " " + reason + "=" + std::to_string(n);
  }
  std::printf("replayed %lld messages: %lld scans applied, skipped:%s; map hash %s\n",
              static_cast<long long>(log.events_read()),
              static_cast<long long>(mapper.scans_applied()),
              skipped.empty() ? " none" : skipped.c_str(), HashText(mapper.map_hash()).c_str());
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  std::string save_path, octomap_path, ply_path, replay_path;
  return kestrel::RunProcess(
      "kestrel-mapper", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--save", save_path);
        app.add_option("--export-octomap", octomap_path);
        app.add_option("--export-ply", ply_path);
        app.add_option("--replay", replay_path);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        kestrel::MapperConfig config = kestrel::LoadMapperConfig(node);
        node.CheckNoUnknownKeys();
        // No run_id set: the run's, from the runner that started it (docs/design.md §3.5).
        if (config.run_id.empty()) config.run_id = kestrel::RunIdFromEnvironment();
        if (!replay_path.empty())
          return Replay(replay_path, config, save_path, octomap_path, ply_path);
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        const std::unique_ptr<kestrel::Clock> clock =
            kestrel::MakeProcessClock(lcm, args.sim_clock_channel);
        kestrel::MapperNode mapper(lcm, config, *clock);
        const kestrel::ConfigPublisher params(lcm, *clock, "kestrel-mapper",
                                              kestrel::ParamsChannelFor(config.heartbeat_channel),
                                              args, node);
        if (mapper.resumed() && !config.catch_up_log.empty()) CatchUp(lcm, mapper, config);
        while (!kestrel::NodeLoop::signal_received()) {
          // Drain the socket into the node's queue first, so the backlog is visible, then apply
          // one scan at a time.
          while (lcm.handleTimeout(0) > 0) {
          }
          const int done = mapper.ProcessPending(1);
          mapper.PublishDue();
          if (done == 0) lcm.handleTimeout(10);
        }
        kestrel::Log(kestrel::LogLevel::kInfo, "stopping: applying what can be applied, saving");
        while (lcm.handleTimeout(0) > 0) {
        }
        mapper.ApplyRemaining();
        mapper.PublishStatus();
        mapper.SaveCheckpoint();
        if (!save_path.empty()) mapper.SaveMapFile(save_path);
        if (!octomap_path.empty()) mapper.ExportOctoMapFile(octomap_path);
        if (!ply_path.empty()) mapper.ExportPlyFile(ply_path);
        kestrel::Log(kestrel::LogLevel::kInfo,
                     "stopped: " + std::to_string(mapper.scans_applied()) +
                         " scans applied (this life), map hash " + HashText(mapper.map_hash()));
        return 0;
      });
}

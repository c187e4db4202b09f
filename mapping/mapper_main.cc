// kestrel-mapper: fuses depth images and planar scans into the exact 3D occupancy map.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <thread>
#include <tuple>

#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/config_publisher.h"
#include "common/identity.h"
#include "common/lcm_decode.h"
#include "common/log.h"
#include "common/log_tail.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "common/sim_truth_clock.h"
#include "mapping/map_decisions.h"
#include "mapping/mapper_node.h"

namespace {
const char* const kUsage =
    "usage: kestrel-mapper [--config config/mapper.yaml] [--set key=value]... [--lcm-url URL]\n"
    "                      [--save FILE] [--export-octomap FILE.bt|.ot] [--export-ply FILE]\n"
    "                      [--replay LOG [--decisions FILE | --ignore-decisions]]\n"
    "Subscribes to the sensors and poses of its configuration, publishes MAP3D snapshots,\n"
    "MAP3D_DELTA, MAP_STATUS and a heartbeat, checkpoints the map, and on exit (SIGINT/SIGTERM)\n"
    "applies what it can, saves the checkpoint and the files asked for. A mapper resumed from its\n"
    "checkpoint first catches up from catch_up_log. Every decision on a queued scan (applied:\n"
    "which rays, which pose; skipped: why) goes out on MAP_DECISIONS and into decisions_log.\n"
    "--replay LOG feeds a recorded log into a fresh map instead, with no live input and no\n"
    "checkpoint, following the live mapper's decisions (from FILE, its decisions_log, whose\n"
    "scans are used first, else from LOG's MAP_DECISIONS; none recorded or --ignore-decisions:\n"
    "as a mapper that kept up), then saves the files asked for; exit 1 if a decision names a\n"
    "scan neither log holds. Both print the map hash at the end.\n";

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

// The recorded decisions (docs/design.md §3.6) of the mapper that ran last, from `source` (an
// LCM log holding map_decisions_t on `channel`): the history of its map. Empty with no decision
// recorded; throws std::runtime_error if the history is incomplete.
std::vector<kestrel::map_decision_t> RecordedDecisions(const std::string& source,
                                                       const std::string& channel,
                                                       std::string* summary) {
  kestrel::DecisionHistory history;
  kestrel::LogTail log(source);
  int64_t refused = 0;
  while (const std::optional<kestrel::LoggedEvent> e = log.Next()) {
    if (e->channel != channel) continue;
    kestrel::map_decisions_t m;
    std::string why;
    if (!kestrel::GuardedDecode(e->data.data(), e->data.size(), &m, &why) ||
        !history.Add(m, &why)) {
      ++refused;  // a malformed message on the channel (kestrel-fault's, say): not the mapper's
      if (refused == 1)
        kestrel::Log(kestrel::LogLevel::kWarning, source + ": " + channel + ": " + why);
      continue;
    }
  }
  if (history.lives().empty()) return {};
  const int64_t last = history.lives().back();
  std::string why;
  std::vector<kestrel::map_decision_t> decisions = history.MapOf(last, &why);
  if (decisions.empty()) {
    throw std::runtime_error(source + ": the decisions of the last mapper (epoch " +
                             std::to_string(last) + ") cannot be followed: " + why);
  }
  int64_t skipped = 0, thinned = 0;
  for (const kestrel::map_decision_t& d : decisions) {
    skipped += d.action == kestrel::map_decision_t::ACTION_SKIPPED ? 1 : 0;
    thinned += d.action == kestrel::map_decision_t::ACTION_APPLIED && d.ray_stride > 1 ? 1 : 0;
  }
  *summary = "following " + std::to_string(decisions.size()) + " decisions of " +
             std::to_string(history.lives().size()) + " mapper lives from " + source +
             " (the last, epoch " + std::to_string(last) + ", with " +
             std::to_string(history.decisions_of(last)) + "): " + std::to_string(thinned) +
             " scans thinned, " + std::to_string(skipped) + " skipped" +
             (refused > 0 ? "; " + std::to_string(refused) + " malformed messages ignored" : "");
  return decisions;
}

// How many of the scans the live mapper applied the run's log lacks (the logger missed them
// under load; the decisions log has them), as a sentence.
std::string ScansMissingFrom(const std::string& path, const kestrel::MapperConfig& config,
                             const std::vector<kestrel::map_decision_t>& decisions) {
  std::set<std::tuple<std::string, int64_t, int64_t>> applied;
  for (const kestrel::map_decision_t& d : decisions) {
    if (d.action == kestrel::map_decision_t::ACTION_APPLIED)
      applied.insert({d.channel, d.epoch, d.seq});
  }
  const size_t total = applied.size();
  std::set<std::string> depth_channels, scan_channels;
  for (const std::string& prefix : config.vehicle_prefixes) {
    for (const kestrel::MapperSensorConfig& s : config.sensors) {
      (s.kind == "depth" ? depth_channels : scan_channels).insert(prefix + s.channel);
    }
  }
  kestrel::LogTail log(path);
  while (const std::optional<kestrel::LoggedEvent> e = log.Next()) {
    std::string why;
    if (depth_channels.count(e->channel) != 0) {
      kestrel::depth_image_t m;
      if (kestrel::GuardedDecode(e->data.data(), e->data.size(), &m, &why)) {
        applied.erase({e->channel, m.epoch, m.seq});
      }
    } else if (scan_channels.count(e->channel) != 0) {
      kestrel::planar_scan_t m;
      if (kestrel::GuardedDecode(e->data.data(), e->data.size(), &m, &why)) {
        applied.erase({e->channel, m.epoch, m.seq});
      }
    }
  }
  return std::to_string(applied.size()) + " of the " + std::to_string(total) +
         " scans the live mapper applied are not in " + path +
         " (the logger missed them); taken from the decisions log";
}

// --replay: the log into a fresh map, in log order. With the live mapper's decisions recorded
// (in DECISIONS, or else on the decisions channel of the log itself), they are followed: the map
// is the live one whatever its load; without (or with --ignore-decisions), as a mapper that kept
// up would have made it.
int Replay(const std::string& path, kestrel::MapperConfig config, const std::string& decisions_path,
           bool ignore_decisions, const std::string& save_path, const std::string& octomap_path,
           const std::string& ply_path) {
  // A batch run: Ctrl-C or SIGTERM ends it at once (a half-replayed map is worth nothing).
  kestrel::NodeLoop::RestoreDefaultSignalActions();
  config.checkpoint_path.clear();  // never resume or overwrite a live mapper's checkpoint
  config.catch_up_log.clear();
  config.decisions_log.clear();
  std::string summary = "no decision followed (--ignore-decisions)";
  std::vector<kestrel::map_decision_t> decisions;
  if (!ignore_decisions) {
    decisions = RecordedDecisions(decisions_path.empty() ? path : decisions_path,
                                  config.decisions_channel, &summary);
    if (decisions.empty()) summary = "no decision recorded: replayed as a mapper that kept up";
  }
  std::printf("%s\n", summary.c_str());
  lcm::LCM lcm("memq://");
  kestrel::SimClock clock(0);
  kestrel::MapperNode mapper(lcm, config, clock);
  const bool following = !decisions.empty();
  const std::vector<kestrel::map_decision_t> mapper_decisions = decisions;
  if (following) mapper.FollowDecisions(std::move(decisions));
  // Following decisions, the scans come from the decisions log first (it holds every scan the
  // live mapper applied, as received), then from the run's log.
  int64_t events = 0;
  const auto feed = [&](const std::string& file) {
    kestrel::LogTail log(file);
    while (const std::optional<kestrel::LoggedEvent> e = log.Next()) {
      if (e->timestamp > clock.NowUtime()) clock.SetUtime(e->timestamp);
      mapper.HandleRecorded(e->channel, e->data.data(), e->data.size());
    }
    events += log.events_read();
  };
  std::string missing_from_log;
  if (following && !decisions_path.empty() && decisions_path != path) {
    feed(decisions_path);
    missing_from_log = ScansMissingFrom(path, config, mapper_decisions);
  }
  feed(path);
  mapper.ApplyRemaining();
  if (!save_path.empty()) mapper.SaveMapFile(save_path);
  if (!octomap_path.empty()) mapper.ExportOctoMapFile(octomap_path);
  if (!ply_path.empty()) mapper.ExportPlyFile(ply_path);
  std::string skipped;
  for (const auto& [reason, n] : mapper.skipped().counts()) {
    skipped += " " + reason + "=" + std::to_string(n);
  }
  std::printf("replayed %lld messages: %lld scans applied, skipped:%s; map hash %s\n",
              static_cast<long long>(events), static_cast<long long>(mapper.scans_applied()),
              skipped.empty() ? " none" : skipped.c_str(), HashText(mapper.map_hash()).c_str());
  if (!missing_from_log.empty()) std::printf("%s\n", missing_from_log.c_str());
  const std::deque<kestrel::map_decision_t>& left = mapper.decisions_to_follow();
  if (!left.empty()) {
    const kestrel::map_decision_t& d = left.front();
    std::printf(
        "FAILED to follow %zu decisions: the scan of the first, %s seq %lld of epoch %lld "
        "(applied live), is in neither log: this map is not the live one\n",
        left.size(), d.channel.c_str(), static_cast<long long>(d.seq),
        static_cast<long long>(d.epoch));
    return 1;
  }
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  std::string save_path, octomap_path, ply_path, replay_path, decisions_path;
  bool ignore_decisions = false;
  return kestrel::RunProcess(
      "kestrel-mapper", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--save", save_path);
        app.add_option("--export-octomap", octomap_path);
        app.add_option("--export-ply", ply_path);
        app.add_option("--replay", replay_path);
        app.add_option("--decisions", decisions_path);
        app.add_flag("--ignore-decisions", ignore_decisions);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode& node) {
        kestrel::MapperConfig config = kestrel::LoadMapperConfig(node);
        node.CheckNoUnknownKeys();
        // No run_id set: the run's, from the runner that started it (docs/design.md §3.5).
        if (config.run_id.empty()) config.run_id = kestrel::RunIdFromEnvironment();
        if (!replay_path.empty()) {
          return Replay(replay_path, config, decisions_path, ignore_decisions, save_path,
                        octomap_path, ply_path);
        }
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
        mapper.PublishDecisions();  // the last ones (SaveCheckpoint sent them if it saves one)
        if (!save_path.empty()) mapper.SaveMapFile(save_path);
        if (!octomap_path.empty()) mapper.ExportOctoMapFile(octomap_path);
        if (!ply_path.empty()) mapper.ExportPlyFile(ply_path);
        kestrel::Log(kestrel::LogLevel::kInfo,
                     "stopped: " + std::to_string(mapper.scans_applied()) +
                         " scans applied (this life), map hash " + HashText(mapper.map_hash()));
        return 0;
      });
}

#include "mapping/mapper_node.h"

#include <sys/stat.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "common/check.h"
#include "common/fnv1a.h"
#include "common/identity.h"
#include "common/log_tail.h"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/map_decisions_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "lcmtypes/message_codecs.h"

namespace kestrel {

namespace {

constexpr int kBlockEdge = GrowingGrid::kBlockEdge;
constexpr int kBlockCells = GrowingGrid::kBlockCells;
constexpr int kMaxRayStride = 16;
// A delta's encoding: 84 bytes of fields (fingerprint included), then 3 x int32 + a float per cell.
constexpr size_t kDeltaHeaderBytes = 84;
constexpr size_t kDeltaCellBytes = 16;
// One scan can change more cells than a message holds (a few per cent of depth images in the
// simulated lasr flight, up to 22 000 cells): a delta up to this many messages' worth still goes
// out as one (it fits in an empty 212 992-byte buffer); a larger one becomes a snapshot.
constexpr size_t kMaxDeltaMessages = 3;

bool FileExists(const std::string& path) {
  struct stat st {};
  return stat(path.c_str(), &st) == 0;
}

int32_t FloorDiv(int32_t a, int32_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// Where another run's checkpoint goes: <path>.run-<its run id> (characters a file name should
// not hold replaced by '_'; "none" when it has no run id), then .2, .3, ... if that exists.
std::string AsideName(const std::string& path, const std::string& run_id) {
  std::string id = run_id.empty() ? "none" : run_id.substr(0, 128);
  for (char& c : id) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '.' || c == '_' || c == '-' || c == '+' || c == ':';
    if (!ok) c = '_';
  }
  const std::string base = path + ".run-" + id;
  std::string aside = base;
  for (int k = 2; FileExists(aside); ++k) aside = base + "." + std::to_string(k);
  return aside;
}

std::string DescribeStreams(const StreamSequences& sequences) {
  std::string out;
  for (const auto& [name, epochs] : sequences) {
    for (const EpochSequence& e : epochs) {
      out += " " + name + "@" + std::to_string(e.last_seq) + " (epoch " + std::to_string(e.epoch) +
             ")";
    }
  }
  return out;
}

}  // namespace

MapperNode::MapperNode(lcm::LCM& lcm, const MapperConfig& config, const Clock& clock)
    : lcm_(lcm),
      config_(config),
      clock_(clock),
      epoch_(NewPublisherEpoch()),
      poses_(config.vehicle_prefixes.size(), PoseHistory(config.pose_history)),
      vehicle_latest_utime_(config.vehicle_prefixes.size(), 0),
      skipped_(clock),
      bad_poses_(clock),
      heartbeat_(lcm, clock, "kestrel-mapper", config.heartbeat_channel),
      subscriptions_(lcm) {
  config_.Validate();
  run_id_ = config_.run_id.empty() ? NewRunId() : config_.run_id;
  if (!config_.checkpoint_path.empty()) {
    Log(LogLevel::kInfo, "run '" + run_id_ + "'" +
                             (config_.run_id.empty() ? " (a fresh id: run_id is not set)" : "") +
                             ", checkpoint " + config_.checkpoint_path);
  }
  for (const auto& s : config_.sensors) {
    models_.emplace_back(s.model);
    mounts_.push_back(s.CalibratedMount());
    stamp_offsets_us_.push_back(SecondsToUtime(s.stamp_offset_s));
  }
  if (!config_.checkpoint_path.empty() && FileExists(config_.checkpoint_path)) {
    LoadCheckpoint();
  } else {
    CreateEmptyMap();
  }
  CreateIntegrator();
  if (!config_.decisions_log.empty()) {
    // A life killed while writing a scan leaves part of it at the end: cut, or this life's
    // decisions would sit behind it where no reader finds them.
    try {
      const int64_t cut = TrimPartialLastEvent(config_.decisions_log);
      if (cut > 0) {
        Log(LogLevel::kWarning, "decisions_log " + config_.decisions_log + ": cut " +
                                    std::to_string(cut) +
                                    " bytes of an event the previous life was writing when it "
                                    "stopped");
      }
    } catch (const std::exception& e) {
      Log(LogLevel::kError, e.what());
    }
    decisions_log_ = std::make_unique<lcm::LogFile>(config_.decisions_log, "a");
    if (!decisions_log_->good()) {
      decisions_log_.reset();
      Log(LogLevel::kError, "cannot append to decisions_log " + config_.decisions_log + ": " +
                                std::strerror(errno) + "; decisions go out on " +
                                config_.decisions_channel + " only");
      heartbeat_.SetLastError("decisions_log not writable: " + config_.decisions_log);
    }
  }
  auto on_error = [this](const std::string& channel, const std::string& reason) {
    skipped_.Count("malformed", channel + ": " + reason);
  };
  // Every vehicle's poses and sensors, on its prefixed channels (docs/design.md §7.10).
  for (size_t v = 0; v < config_.vehicle_prefixes.size(); ++v) {
    const std::string& prefix = config_.vehicle_prefixes[v];
    subscriptions_.Add<pose_t>(
        prefix + config_.pose_channel,
        [this, v](const std::string&, const pose_t& m) { OnPose(v, m); },
        [this](const std::string& channel, const std::string& reason) {
          bad_poses_.Count("malformed_pose", channel + ": " + reason);
        });
    for (size_t i = 0; i < config_.sensors.size(); ++i) {
      const auto& s = config_.sensors[i];
      if (s.kind == "depth") {
        subscriptions_.Add<depth_image_t>(
            prefix + s.channel,
            [this, i, v](const std::string& ch, const depth_image_t& m) { OnDepth(i, v, ch, m); },
            on_error);
      } else {
        subscriptions_.Add<planar_scan_t>(
            prefix + s.channel,
            [this, i, v](const std::string& ch, const planar_scan_t& m) { OnScan(i, v, ch, m); },
            on_error);
      }
    }
  }
  heartbeat_.SetState(heartbeat_t::STATE_OK);
}

void MapperNode::CreateEmptyMap() {
  double max_range = 0.0;
  for (const auto& s : config_.sensors) max_range = std::max(max_range, s.model.z_max_m);
  if (config_.model == "log_odds") {
    KESTREL_THROW_UNLESS(config_.grid == "dense", "the log-odds baseline runs on the dense grid");
    map_ = MakeLogOddsDenseMap(config_.limits, config_.log_odds, max_range);
  } else if (config_.grid == "dense") {
    map_ = MakeExactDenseMap(config_.limits, config_.occupancy, max_range);
  } else {
    map_ = MakeExactGrowingMap(config_.limits, config_.occupancy, max_range);
  }
}

void MapperNode::CreateIntegrator() {
  const ScanIntegrator::Options options{config_.traversal_thread, config_.instruction_set};
  integrator_ =
      std::visit([&](auto& m) { return std::make_unique<ScanIntegrator>(m.get(), options); }, map_);
  std::string supported;
  for (const std::string& name : ScanIntegrator::SupportedInstructionSets()) {
    supported += (supported.empty() ? "" : ", ") + name;
  }
  Log(LogLevel::kInfo, std::string("kernels: ") + integrator_->instruction_set() +
                           " (this CPU runs " + supported +
                           "; instruction_set or KESTREL_ISA "
                           "choose, the map is the same with each)");
}

void MapperNode::RefuseCheckpoint(const std::string& why) {
  const std::string& path = config_.checkpoint_path;
  const std::string aside = path + ".corrupt";
  std::rename(path.c_str(), aside.c_str());
  Log(LogLevel::kError,
      "checkpoint refused (" + why + "); moved to " + aside + "; starting an empty map");
  heartbeat_.SetLastError("checkpoint refused: " + why);
  sequences_.clear();
  CreateEmptyMap();
}

void MapperNode::LoadCheckpoint() {
  const std::string& path = config_.checkpoint_path;
  MapFileInfo info;
  try {
    info = ReadMapFileInfo(path);
  } catch (const std::exception& e) {
    RefuseCheckpoint(e.what());
    return;
  }
  // Another run's checkpoint (docs/design.md §3.5): set aside, never overwritten, unless asked.
  if (info.run_id != run_id_ && config_.resume != "any") {
    const std::string aside = AsideName(path, info.run_id);
    if (std::rename(path.c_str(), aside.c_str()) != 0) {
      throw std::runtime_error("checkpoint " + path + " is of run '" + info.run_id +
                               "', not of this run '" + run_id_ + "', and cannot be moved to " +
                               aside + " (" + std::strerror(errno) + "); refusing to overwrite it");
    }
    Log(LogLevel::kWarning,
        "checkpoint " + path + " is of run '" + info.run_id + "', not of this run '" + run_id_ +
            "' (resume: same_run): not resumed, moved to " + aside + "; starting an empty map");
    CreateEmptyMap();
    return;
  }
  try {
    if (config_.grid == "dense") {
      auto loaded = LoadDenseMap(path);
      KESTREL_THROW_UNLESS(
          loaded.map->grid().geometry().resolution_m() == config_.limits.resolution_m &&
              loaded.map->grid().geometry().origin_m() == config_.limits.min_m,
          "its grid differs from the configured map");
      map_ = std::move(loaded.map);
      sequences_ = std::move(loaded.sequences);
    } else {
      auto loaded = LoadGrowingMap(path);
      KESTREL_THROW_UNLESS(
          loaded.map->grid().geometry().resolution_m() == config_.limits.resolution_m &&
              loaded.map->grid().geometry().origin_m() == config_.limits.min_m,
          "its grid differs from the configured map");
      map_ = std::move(loaded.map);
      sequences_ = std::move(loaded.sequences);
    }
  } catch (const std::exception& e) {
    RefuseCheckpoint(e.what());
    return;
  }
  resumed_ = true;
  // The decisions the checkpoint holds (docs/design.md §3.6): not an input stream.
  const auto history = sequences_.find(kDecisionHistoryStream);
  if (history != sequences_.end()) {
    lives_ = history->second;
    sequences_.erase(history);
  }
  const std::string whose = info.run_id == run_id_
                                ? "of this run"
                                : "of run '" + info.run_id + "' (resume: any) into this run";
  Log(LogLevel::kInfo, "resumed from checkpoint " + path + " " + whose + " '" + run_id_ +
                           "':" + DescribeStreams(sequences_));
}

// docs/design.md §3.4: a message was applied before when an earlier message of the same
// publisher epoch on the same channel had a sequence number at least as high. Every epoch ever
// applied counts, not only the latest: a log replayed into a resumed mapper repeats the
// publishers' restarts, and the messages of an earlier epoch must still be recognised.
bool MapperNode::AlreadyApplied(const std::string& channel, int64_t epoch, int64_t seq) {
  const auto it = sequences_.find(channel);
  if (it == sequences_.end()) return false;
  for (const EpochSequence& e : it->second) {
    if (e.epoch != epoch) continue;
    if (seq > e.last_seq) return false;
    skipped_.Count("already_applied", channel + " seq " + std::to_string(seq) + " of epoch " +
                                          std::to_string(epoch) + " was applied (last " +
                                          std::to_string(e.last_seq) + ")");
    return true;
  }
  return false;
}

void MapperNode::Record(const Pending& p) {
  std::vector<EpochSequence>& epochs = sequences_[p.channel];
  for (EpochSequence& e : epochs) {
    if (e.epoch == p.epoch) {
      e.last_seq = std::max(e.last_seq, p.seq);
      return;
    }
  }
  if (!epochs.empty()) {
    ++publisher_restarts_;
    Log(LogLevel::kInfo, "channel " + p.channel + ": publisher restarted (epoch " +
                             std::to_string(epochs.back().epoch) + " -> " +
                             std::to_string(p.epoch) + ")");
  }
  epochs.push_back(EpochSequence{p.epoch, p.seq});
}

void MapperNode::OnPose(size_t vehicle, const pose_t& msg) {
  if (!msg.valid) return;  // motion capture lost the body: the gap check skips scans across it
  Pose3 X_WB;
  bool finite = true;
  for (double v : msg.position_m) finite = finite && std::isfinite(v);
  if (!finite || !QuaternionFromWxyz(msg.orientation_wxyz, &X_WB.q)) {
    bad_poses_.Count("nan_pose", "pose seq " + std::to_string(msg.seq) +
                                     " has a non-finite position or a non-unit quaternion");
    return;
  }
  X_WB.p = Eigen::Vector3d(msg.position_m[0], msg.position_m[1], msg.position_m[2]);
  if (!poses_[vehicle].Add(msg.utime, X_WB)) {
    bad_poses_.Count("pose_out_of_order",
                     "pose at " + std::to_string(msg.utime) + " us is not newer than the latest");
  } else if (pose_observer_) {
    pose_observer_(vehicle, msg.utime, X_WB);
  }
  latest_input_utime_ = std::max(latest_input_utime_, msg.utime);
  vehicle_latest_utime_[vehicle] = std::max(vehicle_latest_utime_[vehicle], msg.utime);
}

bool MapperNode::AlreadyQueued(const std::string& channel, int64_t epoch, int64_t seq) {
  for (const Pending& p : queue_) {
    if (p.seq == seq && p.epoch == epoch && p.channel == channel) {
      skipped_.Count("already_applied", channel + " seq " + std::to_string(seq) + " of epoch " +
                                            std::to_string(epoch) + " is already queued");
      return true;
    }
  }
  return false;
}

void MapperNode::NoteArrival(const std::string& channel, int64_t epoch, int64_t seq) {
  const auto [it, first] = last_seen_seq_.try_emplace({channel, epoch}, seq);
  if (first) return;
  if (seq - it->second > 10000) {  // not a loss: a corrupt or foreign seq; counted once
    skipped_.Count("seq_jump", channel + " seq " + std::to_string(it->second) + " -> " +
                                   std::to_string(seq) + " of epoch " + std::to_string(epoch));
    return;
  }
  for (int64_t missing = it->second + 1; missing < seq; ++missing) {
    skipped_.Count("lost_in_transport", channel + " seq " + std::to_string(missing) + " of epoch " +
                                            std::to_string(epoch) + " never arrived");
  }
  it->second = std::max(it->second, seq);
}

void MapperNode::OnDepth(size_t sensor, size_t vehicle, const std::string& channel,
                         const depth_image_t& msg) {
  NoteArrival(channel, msg.epoch, msg.seq);
  if (AlreadyApplied(channel, msg.epoch, msg.seq) || AlreadyQueued(channel, msg.epoch, msg.seq)) {
    return;
  }
  auto bad = [&](const std::string& why) {
    skipped_.Count("malformed", channel + " seq " + std::to_string(msg.seq) + ": " + why);
  };
  auto counts = std::make_shared<std::vector<uint16_t>>();
  const std::string why = DecodeDepthPixels(msg, counts.get());
  if (!why.empty()) return bad(why);
  for (double v : {msg.fx_px, msg.fy_px, msg.depth_scale_m}) {
    if (!(std::isfinite(v) && v > 0))
      return bad("zero, negative or non-finite intrinsics or scale");
  }
  if (!std::isfinite(msg.cx_px) || !std::isfinite(msg.cy_px))
    return bad("non-finite principal point");
  // Every pixel 0 (docs/algorithms.md §3.4): a covered lens reads so, and an indoor scene seldom
  // does. Where a 0 is a no-return such a frame would free everything in range: dropped. Where a
  // 0 is no evidence it is applied as what it is, invalid pixels; said at the first of a run of
  // them and every 150 after.
  int64_t& streak = all_zero_streak_[channel];
  if (std::all_of(counts->begin(), counts->end(), [](uint16_t c) { return c == 0; })) {
    ++all_zero_frames_;
    const std::string what = channel + " seq " + std::to_string(msg.seq) +
                             ": every pixel reads 0 (a covered lens, or nothing between the near "
                             "and far limits)";
    if (config_.sensors[sensor].model.no_return_informs) {
      return skipped_.Count("all_zero", what + ": dropped, as its 0s would be taken as no-returns");
    }
    if (streak++ % 150 == 0) {
      Log(LogLevel::kWarning, what + ", " + std::to_string(streak) +
                                  " such frames in a row: no evidence, nothing learnt from them");
    }
  } else {
    streak = 0;
  }
  auto metadata = std::make_shared<depth_image_t>(msg);
  metadata->data.clear();  // the pixels travel decoded, in counts
  metadata->data_size = 0;
  Enqueue(Pending{msg.utime, msg.seq, msg.epoch, sensor, vehicle, channel, std::move(metadata),
                  std::move(counts), nullptr, RawForLog(msg)});
}

void MapperNode::OnScan(size_t sensor, size_t vehicle, const std::string& channel,
                        const planar_scan_t& msg) {
  NoteArrival(channel, msg.epoch, msg.seq);
  if (AlreadyApplied(channel, msg.epoch, msg.seq) || AlreadyQueued(channel, msg.epoch, msg.seq)) {
    return;
  }
  auto bad = [&](const std::string& why) {
    skipped_.Count("malformed", channel + " seq " + std::to_string(msg.seq) + ": " + why);
  };
  if (msg.num_ranges <= 0) return bad("no ranges");
  if (!(std::isfinite(msg.angle_min_rad) && std::isfinite(msg.angle_step_rad) &&
        msg.angle_step_rad > 0)) {
    return bad("angle_min/angle_step not finite or step not positive");
  }
  auto scan = std::make_shared<planar_scan_t>(msg);
  for (float& r : scan->ranges_m) {
    if (std::isnan(r)) continue;  // no information: the sensor model drops it
    if (r < 0 || std::isinf(r)) return bad("negative or infinite range " + std::to_string(r));
    if (r == 0.0f) r = std::numeric_limits<float>::infinity();  // "no return"
  }
  Enqueue(Pending{msg.utime, msg.seq, msg.epoch, sensor, vehicle, channel, nullptr, nullptr,
                  std::move(scan), RawForLog(msg)});
}

void MapperNode::Enqueue(Pending p) {
  if (following_) {
    // Held until its decision comes; a scan no decision names was not applied live.
    const ScanKey key{p.channel, p.epoch, p.seq};
    if (followed_keys_.count(key) != 0) {
      arrived_.emplace(key, std::move(p));
    } else {
      skipped_.Count("not_applied_live", p.channel + " seq " + std::to_string(p.seq) +
                                             " of epoch " + std::to_string(p.epoch) +
                                             ": no decision of the live mapper applied it");
    }
    return;
  }
  // A stamp far ahead of the vehicle's poses (a sensor clock that jumped) is not taken as the
  // newest input: it would expire every other scan's wait and decimate (docs/design.md §3.6).
  const int64_t newest_pose = poses_[p.vehicle].newest_utime();
  if (poses_[p.vehicle].size() > 0 &&
      p.utime - newest_pose > SecondsToUtime(config_.max_stamp_lead_s)) {
    std::ostringstream detail;
    detail << "stamped " << UtimeToSeconds(p.utime - newest_pose)
           << " s after the vehicle's newest pose (max_stamp_lead_s = " << config_.max_stamp_lead_s
           << "): the sensor's clock jumped, or the poses stopped; nothing of it applied";
    Skip(p, "stamp_ahead", detail.str());
    return;
  }
  latest_input_utime_ = std::max(latest_input_utime_, p.utime);
  vehicle_latest_utime_[p.vehicle] = std::max(vehicle_latest_utime_[p.vehicle], p.utime);
  int64_t& latest = stream_latest_utime_[{p.vehicle, p.sensor}];
  latest = std::max(latest, p.utime);
  // Order (docs/design.md §3.6): (stamp, vehicle, sensor), then arrival, so that no delay between
  // the vehicles or the sensors' driver processes changes it.
  auto it =
      std::upper_bound(queue_.begin(), queue_.end(), p, [](const Pending& a, const Pending& q) {
        if (a.utime != q.utime) return a.utime < q.utime;
        if (a.vehicle != q.vehicle) return a.vehicle < q.vehicle;
        return a.sensor < q.sensor;
      });
  queue_.insert(it, std::move(p));
  while (static_cast<int>(queue_.size()) > config_.max_queue) {
    Skip(queue_.front(), "overload",
         "queue above max_queue = " + std::to_string(config_.max_queue));
    queue_.pop_front();
  }
}

void MapperNode::Skip(const Pending& p, const std::string& reason, const std::string& detail) {
  skipped_.Count(reason, p.channel + " seq " + std::to_string(p.seq) + " at " +
                             std::to_string(p.utime) + " us: " + detail);
  Record(p);
  Decide(p, map_decision_t::ACTION_SKIPPED, reason, Pose3{});
}

void MapperNode::Decide(const Pending& p, int8_t action, const std::string& reason,
                        const Pose3& X_WB) {
  ++decision_count_;
  if (following_) return;  // a replay: these are the recorded ones
  map_decision_t d{};
  d.channel = p.channel;
  d.epoch = p.epoch;
  d.seq = p.seq;
  d.scan_utime = p.utime;
  d.action = action;
  d.ray_stride = static_cast<int16_t>(action == map_decision_t::ACTION_APPLIED ? ray_stride_ : 1);
  d.reason = reason;
  for (int a = 0; a < 3; ++a) d.position_m[a] = X_WB.p[a];
  d.orientation_wxyz[0] = X_WB.q.w();
  d.orientation_wxyz[1] = X_WB.q.x();
  d.orientation_wxyz[2] = X_WB.q.y();
  d.orientation_wxyz[3] = X_WB.q.z();
  decisions_.push_back(std::move(d));
  if (decisions_.size() >= 64) PublishDecisions();
}

void MapperNode::PublishDecisions() {
  if (decisions_.empty()) return;
  map_decisions_t m{};
  m.utime = clock_.NowUtime();
  m.seq = decisions_seq_++;
  m.epoch = epoch_;
  m.first_index = decision_count_ - static_cast<int64_t>(decisions_.size());
  m.num_decisions = static_cast<int32_t>(decisions_.size());
  m.decisions = std::move(decisions_);
  decisions_.clear();
  m.num_lives = static_cast<int32_t>(lives_.size());
  for (const EpochSequence& life : lives_) {
    m.life_epochs.push_back(life.epoch);
    m.life_decisions.push_back(life.last_seq);
  }
  lcm_.publish(config_.decisions_channel, &m);
  last_decisions_utime_ = m.utime;
  if (!decisions_log_) return;
  std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  // Flushed at once (the scans written before it too): a mapper killed with -9 has written every
  // decision it published.
  WriteDecisionsLog(config_.decisions_channel, bytes, m.utime, true);
}

void MapperNode::FollowDecisions(std::vector<map_decision_t> decisions) {
  following_ = true;
  for (map_decision_t& d : decisions) {
    if (d.action == map_decision_t::ACTION_APPLIED) ++followed_keys_[{d.channel, d.epoch, d.seq}];
    to_follow_.push_back(std::move(d));
  }
}

int MapperNode::FollowPending() {
  int done = 0;
  while (!to_follow_.empty()) {
    const map_decision_t& d = to_follow_.front();
    Pending p{d.scan_utime, d.seq, d.epoch, 0, 0, d.channel, nullptr, nullptr, nullptr, nullptr};
    if (d.action != map_decision_t::ACTION_APPLIED) {
      skipped_.Count(d.reason, d.channel + " seq " + std::to_string(d.seq) + " at " +
                                   std::to_string(d.scan_utime) + " us: as decided live");
      Record(p);
      ++decision_count_;
    } else {
      const ScanKey key{d.channel, d.epoch, d.seq};
      const auto arrived = arrived_.find(key);
      if (arrived == arrived_.end()) break;  // its scan is still to come
      Pose3 X_WB;
      X_WB.p = Eigen::Vector3d(d.position_m[0], d.position_m[1], d.position_m[2]);
      X_WB.q = Eigen::Quaterniond(d.orientation_wxyz[0], d.orientation_wxyz[1],
                                  d.orientation_wxyz[2], d.orientation_wxyz[3]);
      ray_stride_ = std::max<int>(1, d.ray_stride);
      if (ray_stride_ > 1) decimated_ever_ = true;
      // The decided pose was looked up at the stamp less the sensor's offset (as configured).
      Apply(arrived->second, X_WB,
            arrived->second.utime - stamp_offsets_us_[arrived->second.sensor]);
      arrived_.erase(arrived);
      if (--followed_keys_[key] == 0) followed_keys_.erase(key);
    }
    to_follow_.pop_front();
    ++done;
  }
  return done;
}

int MapperNode::ApplyRemaining() {
  input_ended_ = true;
  const int done = ProcessPending();
  input_ended_ = false;
  return done;
}

bool MapperNode::StreamsPassed(int64_t utime) const {
  if (config_.order_wait_s <= 0 || input_ended_) return true;
  if (latest_input_utime_ - utime >= SecondsToUtime(config_.order_wait_s)) return true;
  // Every configured stream (vehicle, sensor), sent yet or not: a stream whose first scans are
  // still on their way is waited for too (a sensor that never sends delays the map by
  // order_wait_s).
  for (size_t v = 0; v < config_.vehicle_prefixes.size(); ++v) {
    for (size_t i = 0; i < config_.sensors.size(); ++i) {
      const auto it = stream_latest_utime_.find({v, i});
      if (it == stream_latest_utime_.end() || it->second < utime) return false;
    }
  }
  return true;
}

int MapperNode::ProcessPending(int max_scans) {
  if (following_) return FollowPending();
  int done = 0;
  while (!queue_.empty() && (max_scans <= 0 || done < max_scans)) {
    const Pending& front = queue_.front();
    // Several vehicles: a scan still on its way from another stream may come before it.
    if (!StreamsPassed(front.utime)) break;
    Pose3 X_WB;
    // The wait for a newer pose is bounded in message time (the newest input stamp of the scan's
    // own vehicle: another vehicle's link may be faster), not wall time, so a log replayed at any
    // speed pairs exactly as it did live. The pose is the one at the stamp less the sensor's
    // calibrated stamp offset (docs/algorithms.md §3.7).
    const int64_t pose_utime = front.utime - stamp_offsets_us_[front.sensor];
    const PoseLookupResult r =
        poses_[front.vehicle].Lookup(pose_utime, vehicle_latest_utime_[front.vehicle], &X_WB);
    if (r == PoseLookupResult::kWait) break;
    if (r != PoseLookupResult::kOk) {
      Skip(front, ToString(r), "no pose to pair it with");
    } else {
      // Overload policy (file comment): decimate while the backlog exceeds max_backlog_s.
      const double backlog_s = UtimeToSeconds(latest_input_utime_ - front.utime);
      const int stride_before = ray_stride_;
      if (backlog_s > config_.max_backlog_s) {
        ray_stride_ = std::min(kMaxRayStride, ray_stride_ * 2);
      } else if (ray_stride_ > 1 && backlog_s < 0.5 * config_.max_backlog_s) {
        ray_stride_ /= 2;
      }
      if (ray_stride_ > 1) decimated_ever_ = true;
      if (ray_stride_ != stride_before) {
        Log(LogLevel::kWarning, "overload: ray stride " + std::to_string(stride_before) + " -> " +
                                    std::to_string(ray_stride_) + " (one ray in " +
                                    std::to_string(ray_stride_) + ") from " + front.channel +
                                    " seq " + std::to_string(front.seq) + " on (backlog " +
                                    std::to_string(backlog_s) + " s, max_backlog_s " +
                                    std::to_string(config_.max_backlog_s) + ")");
      }
      Apply(front, X_WB, pose_utime);
      // A delta goes out as soon as it fills the largest map message (docs/design.md §7.6).
      if (config_.delta_period_s > 0 && ChangedCellCount() >= MaxDeltaCells()) PublishDelta();
    }
    queue_.pop_front();
    ++done;
  }
  return done;
}

void MapperNode::Apply(const Pending& p, const Pose3& X_WB, int64_t pose_utime) {
  const SensorModel& model = models_[p.sensor];
  const Pose3 X_WS = X_WB * mounts_[p.sensor];
  const int k = ray_stride_;
  ScanStats stats;
  ScanIntegrator* const integrator = integrator_.get();
  AppliedScan applied;
  applied.utime = p.utime;
  applied.pose_utime = pose_utime;
  applied.sensor = p.sensor;
  applied.vehicle = p.vehicle;
  applied.X_WS = X_WS;
  applied.model = &model;
  std::vector<uint16_t> sub_counts;
  std::vector<float> sub_ranges;
  if (p.depth) {
    const depth_image_t& img = *p.depth;
    const uint16_t* depth = p.counts->data();
    // Every k-th pixel in both directions; pixel centres stay exact with scaled intrinsics.
    const DepthIntrinsics in{img.fx_px / k, img.fy_px / k, img.cx_px / k, img.cy_px / k};
    int w = img.width, h = img.height;
    if (k > 1) {
      w = (img.width + k - 1) / k, h = (img.height + k - 1) / k;
      sub_counts.resize(static_cast<size_t>(w) * static_cast<size_t>(h));
      for (int v = 0; v < h; ++v) {
        for (int u = 0; u < w; ++u) sub_counts[v * w + u] = depth[(v * k) * img.width + u * k];
      }
      depth = sub_counts.data();
    }
    stats = integrator->IntegrateDepthImage(X_WS, in, depth, w, h, img.depth_scale_m, model);
    applied.depth_counts = depth;
    applied.width = w;
    applied.height = h;
    applied.depth_scale_m = img.depth_scale_m;
    applied.intrinsics = in;
  } else {
    const planar_scan_t& s = *p.scan;
    const float* ranges = s.ranges_m.data();
    int n = s.num_ranges;
    double step = s.angle_step_rad;
    if (k > 1) {
      for (int i = 0; i < s.num_ranges; i += k) sub_ranges.push_back(s.ranges_m[i]);
      ranges = sub_ranges.data();
      n = static_cast<int>(sub_ranges.size());
      step = s.angle_step_rad * static_cast<float>(k);
    }
    stats = integrator->IntegratePlanarScan(X_WS, s.angle_min_rad, step, ranges, n, model);
    applied.ranges_m = ranges;
    applied.num_ranges = n;
    applied.angle_min_rad = s.angle_min_rad;
    applied.angle_step_rad = step;
  }
  if (scan_observer_) scan_observer_(applied);
  rays_total_ += stats.rays_applied;
  cells_total_ += stats.cells_updated;
  ++map_seq_;
  ++scans_applied_;
  newest_applied_utime_ = std::max(newest_applied_utime_, p.utime);
  Record(p);
  // The scan itself into decisions_log, before its decision: the run's log may lack it.
  if (decisions_log_ && p.raw && !following_) {
    WriteDecisionsLog(p.channel, *p.raw, p.utime, false);
  }
  Decide(p, map_decision_t::ACTION_APPLIED, "", X_WB);
}

template <class Message>
std::shared_ptr<const std::vector<uint8_t>> MapperNode::RawForLog(const Message& msg) const {
  if (!decisions_log_ || following_) return nullptr;
  auto bytes = std::make_shared<std::vector<uint8_t>>(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(bytes->data(), 0, static_cast<int>(bytes->size()));
  return bytes;
}

void MapperNode::WriteDecisionsLog(const std::string& channel, const std::vector<uint8_t>& bytes,
                                   int64_t utime, bool flush) {
  lcm::LogEvent event{};
  event.eventnum = 0;
  event.timestamp = utime;
  event.channel = channel;
  event.datalen = static_cast<int32_t>(bytes.size());
  event.data = const_cast<uint8_t*>(bytes.data());  // NOLINT: LogEvent's data is not const
  if (decisions_log_->writeEvent(&event) != 0 ||
      (flush && std::fflush(decisions_log_->getFilePtr()) != 0)) {
    Log(LogLevel::kError, "decisions_log " + config_.decisions_log +
                              ": write failed: " + std::strerror(errno) + "; no longer written");
    heartbeat_.SetLastError("decisions_log write failed");
    decisions_log_.reset();
  }
}

std::vector<SensorRay> MapperNode::AppliedScan::Rays() const {
  std::vector<SensorRay> rays;
  const Eigen::Matrix3d R_WS = X_WS.q.normalized().toRotationMatrix();
  if (depth_counts != nullptr) {
    rays.reserve(static_cast<size_t>(width) * static_cast<size_t>(height));
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        rays.push_back(DepthPixelRay(X_WS, R_WS, intrinsics, u, v,
                                     depth_counts[static_cast<size_t>(v) * width + u],
                                     depth_scale_m, *model));
      }
    }
  } else {
    rays.reserve(static_cast<size_t>(num_ranges));
    for (int i = 0; i < num_ranges; ++i) {
      rays.push_back(
          PlanarBeamRay(X_WS, R_WS, angle_min_rad, angle_step_rad, i, ranges_m[i], *model));
    }
  }
  return rays;
}

namespace {
// FNV-1a over a message's channel, a NUL and its bytes: the identity of a message in the log and
// live.
uint64_t MessageHash(const std::string& channel, const void* data, size_t size) {
  return Fnv1a(data, size, Fnv1a(channel.c_str(), channel.size() + 1));
}
}  // namespace

void MapperNode::HandleRecorded(const std::string& channel, const void* data, size_t size) {
  subscriptions_.Feed(channel, data, size);
  ProcessPending();
}

void MapperNode::BeginCatchUp() {
  catching_up_ = true;
  catch_up_overlap_ = false;
  held_.clear();
  held_hashes_.clear();
  fed_since_overlap_.clear();
  catch_up_fed_ = 0;
  heartbeat_.SetState(heartbeat_t::STATE_STARTING);
  subscriptions_.SetHold([this](const std::string& channel, const void* data, size_t size) {
    const uint64_t hash = MessageHash(channel, data, size);
    const auto* bytes = static_cast<const uint8_t*>(data);
    held_.push_back(Held{channel, std::vector<uint8_t>(bytes, bytes + size), hash});
    held_hashes_.insert(hash);
  });
}

void MapperNode::FeedCatchUp(const std::string& channel, const void* data, size_t size) {
  KESTREL_DEMAND(catching_up_);
  const uint64_t hash = MessageHash(channel, data, size);
  if (!catch_up_overlap_ && held_hashes_.count(hash) > 0) catch_up_overlap_ = true;
  if (catch_up_overlap_) fed_since_overlap_.insert(hash);
  ++catch_up_fed_;
  HandleRecorded(channel, data, size);
}

MapperNode::CatchUpResult MapperNode::EndCatchUp() {
  KESTREL_DEMAND(catching_up_);
  subscriptions_.SetHold(nullptr);
  catching_up_ = false;
  CatchUpResult r;
  r.fed = catch_up_fed_;
  r.held = static_cast<int64_t>(held_.size());
  r.overlapped = catch_up_overlap_;
  // The held messages in order; those the log also held were handled from it (the live order
  // and the logger's are the same datagrams in the same order on one host).
  for (const Held& h : held_) {
    if (fed_since_overlap_.count(h.hash) > 0) {
      ++r.repeated;
      continue;
    }
    HandleRecorded(h.channel, h.data.data(), h.data.size());
  }
  held_.clear();
  held_hashes_.clear();
  fed_since_overlap_.clear();
  heartbeat_.SetState(heartbeat_t::STATE_OK);
  return r;
}

double MapperNode::entropy_nats() const {
  return std::visit([](const auto& m) { return m->entropy_nats(); }, map_);
}

uint64_t MapperNode::map_hash() const {
  return std::visit([](const auto& m) { return m->Hash(); }, map_);
}

double MapperNode::ProbabilityAt(const CellIndex& cell) const {
  return std::visit([&](const auto& m) { return m->ProbabilityAt(cell); }, map_);
}

double MapperNode::PriorProbability() const {
  return std::visit(
      [](const auto& m) { return m->updater().ProbabilityOf(m->grid().initial_value()); }, map_);
}

const GridGeometry& MapperNode::geometry() const {
  return std::visit([](const auto& m) -> const GridGeometry& { return m->grid().geometry(); },
                    map_);
}

bool MapperNode::applied_every_message() const {
  return skipped_.total() == skipped_.count("already_applied") && !decimated_ever_;
}

void MapperNode::SaveMapFile(const std::string& path) const {
  std::visit([&](const auto& m) { SaveMap(path, *m, sequences_); }, map_);
}

void MapperNode::ExportOctoMapFile(const std::string& path) const {
  std::visit([&](const auto& m) { ExportOctoMap(path, *m); }, map_);
}

size_t MapperNode::ExportPlyFile(const std::string& path) const {
  return std::visit([&](const auto& m) { return ExportOccupiedPly(path, *m); }, map_);
}

template <class F>
void MapperNode::ForEachBlock(F&& f) const {
  std::vector<float> probabilities(kBlockCells);
  if (const auto* dense = std::get_if<std::unique_ptr<DenseOccupancyMap>>(&map_)) {
    const DenseOccupancyMap& map = **dense;
    const DenseGrid& grid = map.grid();
    const OccupancyUpdater& updater = map.updater();
    const CellIndex dims = grid.dims();
    const float untouched = grid.initial_value();
    for (int32_t bz = 0; bz < dims.z; bz += kBlockEdge) {
      for (int32_t by = 0; by < dims.y; by += kBlockEdge) {
        for (int32_t bx = 0; bx < dims.x; bx += kBlockEdge) {
          bool observed = false;
          for (int i = 0; i < kBlockCells; ++i) {
            const CellIndex c{bx + (i & 7), by + ((i >> 3) & 7), bz + (i >> 6)};
            float stored = untouched;
            if (c.x < dims.x && c.y < dims.y && c.z < dims.z) stored = grid.Get(c);
            observed = observed || stored != untouched;
            probabilities[i] = static_cast<float>(updater.ProbabilityOf(stored));
          }
          if (observed) f(CellIndex{bx, by, bz}, probabilities);
        }
      }
    }
    return;
  }
  const GrowingOccupancyMap& map = *std::get<std::unique_ptr<GrowingOccupancyMap>>(map_);
  const OccupancyUpdater& updater = map.updater();
  map.grid().ForEachBlock([&](const CellIndex& origin, const GrowingGrid::Block& block) {
    for (int i = 0; i < kBlockCells; ++i) {
      probabilities[i] = static_cast<float>(updater.ProbabilityOf(block.values[i]));
    }
    f(origin, probabilities);
  });
}

void MapperNode::PublishSnapshot() {
  // A snapshot still on its way goes out whole first: its receivers are assembling it.
  while (!outgoing_chunks_.empty()) {
    lcm_.publish(config_.map_channel, &outgoing_chunks_.front());
    outgoing_chunks_.pop_front();
  }
  const GridGeometry& g = geometry();
  const double p_init = std::visit(
      [](const auto& m) { return m->updater().ProbabilityOf(m->grid().initial_value()); }, map_);
  std::vector<std::pair<CellIndex, std::vector<float>>> blocks;
  ForEachBlock([&](const CellIndex& origin, const std::vector<float>& p) {
    blocks.emplace_back(origin, p);
  });
  std::visit([](auto& m) { m->ClearChanges(); }, map_);  // the next delta starts here
  ++snapshot_id_;
  auto make_chunk = [&](size_t begin, size_t end) {
    map3d_chunk_t msg{};
    msg.utime = newest_applied_utime_;
    msg.snapshot_id = snapshot_id_;
    msg.map_seq = map_seq_;
    msg.epoch = epoch_;
    for (int a = 0; a < 3; ++a) {
      msg.origin_m[a] = g.origin_m()[a];
      msg.dims[a] = g.bounded() ? g.upper()[a] : 0;
    }
    msg.resolution_m = g.resolution_m();
    msg.p_init = p_init;
    msg.block_edge = kBlockEdge;
    std::vector<float> cells;
    for (size_t b = begin; b < end; ++b) {
      const CellIndex& o = blocks[b].first;
      msg.block_index.push_back(
          {FloorDiv(o.x, kBlockEdge), FloorDiv(o.y, kBlockEdge), FloorDiv(o.z, kBlockEdge)});
      cells.insert(cells.end(), blocks[b].second.begin(), blocks[b].second.end());
    }
    msg.num_blocks = static_cast<int32_t>(msg.block_index.size());
    EncodeMapChunkCells(cells, map3d_chunk_t::ENCODING_ZLIB_FLOAT32, 1,
                        &msg);  // zlib level 1: fast
    return msg;
  };
  // Chunks of at most snapshot_blocks_per_chunk blocks, halved while the encoding is larger than
  // map_message_max_bytes (docs/design.md §7.6); the chunks depend only on the map.
  size_t per_chunk = static_cast<size_t>(config_.snapshot_blocks_per_chunk);
  size_t begin = 0;
  do {
    size_t n = std::min(per_chunk, blocks.size() - begin);
    map3d_chunk_t msg = make_chunk(begin, begin + n);
    while (msg.getEncodedSize() > config_.map_message_max_bytes && n > 1) {
      n = (n + 1) / 2;
      per_chunk = n;
      msg = make_chunk(begin, begin + n);
    }
    outgoing_chunks_.push_back(std::move(msg));
    begin += n;
  } while (begin < blocks.size());
  const int num_chunks = static_cast<int>(outgoing_chunks_.size());
  for (int c = 0; c < num_chunks; ++c) {
    outgoing_chunks_[static_cast<size_t>(c)].chunk_index = c;
    outgoing_chunks_[static_cast<size_t>(c)].num_chunks = num_chunks;
  }
  last_delta_map_seq_ = map_seq_;
  next_chunk_utime_ = -1;  // the first chunk now
  SendDueChunk(clock_.NowUtime());
}

void MapperNode::SendDueChunk(int64_t now) {
  if (config_.snapshot_bytes_per_s <= 0) {
    while (!outgoing_chunks_.empty()) {
      lcm_.publish(config_.map_channel, &outgoing_chunks_.front());
      outgoing_chunks_.pop_front();
    }
    return;
  }
  if (outgoing_chunks_.empty() || (next_chunk_utime_ >= 0 && now < next_chunk_utime_)) return;
  const map3d_chunk_t& chunk = outgoing_chunks_.front();
  const double bytes = static_cast<double>(chunk.getEncodedSize());
  lcm_.publish(config_.map_channel, &chunk);
  outgoing_chunks_.pop_front();
  // The next chunk when this one's bytes have gone at the configured rate (from now, so that a
  // jump of the clock never lets chunks out in a burst).
  next_chunk_utime_ = now + SecondsToUtime(bytes / config_.snapshot_bytes_per_s);
}

size_t MapperNode::MaxDeltaCells() const {
  return (static_cast<size_t>(config_.map_message_max_bytes) - kDeltaHeaderBytes) / kDeltaCellBytes;
}

size_t MapperNode::ChangedCellCount() const {
  return std::visit([](const auto& m) { return static_cast<size_t>(m->ChangedCellCount()); }, map_);
}

void MapperNode::PublishDelta() {
  if (map_seq_ == last_delta_map_seq_) return;
  const GridGeometry& g = geometry();
  map3d_delta_t msg{};
  MapDeltaCells changed;
  const bool too_large = std::visit(
      [&](const auto& m) {
        if (m->ChangedCellCount() > kMaxDeltaMessages * MaxDeltaCells()) return true;
        const OccupancyUpdater& updater = m->updater();
        m->ForEachChangedCell([&](const CellIndex& c, float stored) {
          changed.cells.push_back({c.x, c.y, c.z});
          changed.probabilities.push_back(static_cast<float>(updater.ProbabilityOf(stored)));
        });
        return false;
      },
      map_);
  if (too_large) {
    // More than three messages' worth (one scan changed that much): a snapshot instead; while one
    // is being sent, the changes wait for its end and then go out as the next snapshot.
    if (!snapshot_in_flight()) PublishSnapshot();
    return;
  }
  msg.utime = newest_applied_utime_;
  msg.seq = map_seq_;
  msg.epoch = epoch_;
  msg.prev_seq = last_delta_map_seq_;
  msg.base_snapshot_id = snapshot_id_;
  for (int a = 0; a < 3; ++a) msg.origin_m[a] = g.origin_m()[a];
  msg.resolution_m = g.resolution_m();
  // Packed and deflated, exactly (docs/design.md §7.6): about a third of the raw 16 bytes a cell.
  EncodeMapDeltaCells(changed, map3d_delta_t::ENCODING_ZLIB_CELLS, 1, &msg);
  lcm_.publish(config_.delta_channel, &msg);
  std::visit([](auto& m) { m->ClearChanges(); }, map_);
  last_delta_map_seq_ = map_seq_;
}

void MapperNode::PublishStatus() {
  const int64_t now = clock_.NowUtime();
  map_status_t msg{};
  msg.utime = now;
  msg.seq = status_seq_++;
  msg.epoch = epoch_;
  msg.map_seq = map_seq_;
  msg.map_entropy_nats = entropy_nats();
  if (last_status_utime_ >= 0 && now > last_status_utime_) {
    const double dt = UtimeToSeconds(now - last_status_utime_);
    msg.rays_per_s = static_cast<double>(rays_total_ - rays_at_last_status_) / dt;
    msg.cell_updates_per_s = static_cast<double>(cells_total_ - cells_at_last_status_) / dt;
  }
  last_status_utime_ = now;
  rays_at_last_status_ = rays_total_;
  cells_at_last_status_ = cells_total_;
  msg.scans_applied = scans_applied_;
  msg.scans_skipped = skipped_.total();
  for (const auto& [kind, n] : skipped_.counts()) {
    named_value_t v;
    v.name = kind;
    v.value = static_cast<double>(n);
    msg.skip_reasons.push_back(v);
  }
  for (const auto& [kind, n] : bad_poses_.counts()) {
    named_value_t v;
    v.name = kind;
    v.value = static_cast<double>(n);
    msg.skip_reasons.push_back(v);
  }
  msg.num_skip_reasons = static_cast<int32_t>(msg.skip_reasons.size());
  msg.queue_depth = static_cast<int32_t>(queue_.size());
  msg.backlog_s = queue_.empty() ? 0.0 : UtimeToSeconds(latest_input_utime_ - queue_.front().utime);
  msg.ray_decimation = 1.0 / ray_stride_;
  msg.applied_every_message = static_cast<int8_t>(applied_every_message());
  lcm_.publish(config_.status_channel, &msg);

  heartbeat_.SetState(ray_stride_ > 1 || (!queue_.empty() && msg.backlog_s > config_.max_backlog_s)
                          ? heartbeat_t::STATE_DEGRADED
                          : heartbeat_t::STATE_OK);
  heartbeat_.SetValue("map_seq", static_cast<double>(map_seq_));
  heartbeat_.SetValue("rays_per_s", msg.rays_per_s);
  heartbeat_.SetValue("scans_applied", static_cast<double>(scans_applied_));
  heartbeat_.SetValue("scans_skipped", static_cast<double>(skipped_.total()));
  // Scans: dropped.malformed (refused bytes or contents), .already_applied, ...; poses:
  // dropped.malformed_pose, .nan_pose, ... (docs/design.md §7.11).
  heartbeat_.SetDropValues(skipped_);
  heartbeat_.SetDropValues(bad_poses_, {"malformed_pose"});
  heartbeat_.SetValue("queue_depth", static_cast<double>(queue_.size()));
  heartbeat_.SetValue("publisher_restarts", static_cast<double>(publisher_restarts_));
  heartbeat_.SetValue("entropy_nats", msg.map_entropy_nats);
  if (!skipped_.last_reason().empty()) heartbeat_.SetLastError(skipped_.last_reason());
  heartbeat_.Publish();
}

bool MapperNode::SaveCheckpoint() {
  if (config_.checkpoint_path.empty()) return true;
  // Every decision the checkpoint holds is out before it is saved (docs/design.md §3.6), and the
  // checkpoint says which: the history it resumed, then this life's count.
  PublishDecisions();
  StreamSequences sequences = sequences_;
  std::vector<EpochSequence>& history = sequences[kDecisionHistoryStream];
  history = lives_;
  history.push_back(EpochSequence{epoch_, decision_count_});
  try {
    std::visit([&](const auto& m) { SaveMap(config_.checkpoint_path, *m, sequences, run_id_); },
               map_);
    return true;
  } catch (const std::exception& e) {
    Log(LogLevel::kError, std::string("checkpoint not saved: ") + e.what());
    heartbeat_.SetLastError(std::string("checkpoint not saved: ") + e.what());
    return false;
  }
}

void MapperNode::PublishDue() {
  const int64_t now = clock_.NowUtime();
  auto due = [now](int64_t* last, double period_s) {
    if (period_s <= 0) return false;
    if (*last >= 0 && now - *last < SecondsToUtime(period_s)) return false;
    *last = now;
    return true;
  };
  SendDueChunk(now);
  // A new snapshot only once the last one is out (docs/design.md §7.6).
  if (!snapshot_in_flight() && due(&last_snapshot_utime_, config_.snapshot_period_s)) {
    PublishSnapshot();
    last_delta_utime_ = now;
  } else if (due(&last_delta_utime_, config_.delta_period_s)) {
    PublishDelta();
  }
  if (due(&status_due_utime_, config_.status_period_s)) PublishStatus();
  if (!decisions_.empty() && now - last_decisions_utime_ >= 100'000) PublishDecisions();
  if (!config_.checkpoint_path.empty() &&
      due(&last_checkpoint_utime_, config_.checkpoint_period_s)) {
    SaveCheckpoint();
  }
}

}  // namespace kestrel

#include "viewer/report/report_export.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <lcm/lcm-cpp.hpp>

#include "common/check.h"
#include "common/config_publisher.h"
#include "common/lcm_decode.h"
#include "common/se3.h"
#include "exploration/explorer_state.h"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "kestrel/params_t.hpp"
#include "kestrel/pose_t.hpp"
#include "mapping/map_quality.h"
#include "mapping/map_replica.h"
#include "sim/ground_truth.h"
#include "sim/world.h"
#include "sim/world_ray_caster.h"

namespace kestrel {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

/// A CSV field: quoted (quotes doubled) when it holds a comma, a quote or a line break.
std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string out = "\"";
  for (const char c : text) {
    out += c;
    if (c == '"') out += '"';
  }
  return out + "\"";
}

double SecondsBetween(int64_t utime, int64_t origin_utime) {
  return 1e-6 * static_cast<double>(utime - origin_utime);
}

/// A FILE* that closes itself and turns write errors into exceptions.
class CsvFile {
 public:
  explicit CsvFile(const std::string& path) : path_(path), file_(std::fopen(path.c_str(), "w")) {
    if (file_ == nullptr) {
      throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
    }
  }
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;
  ~CsvFile() {
    if (file_ != nullptr) std::fclose(file_);
  }
  FILE* get() { return file_; }
  void Close() {
    const bool failed = std::ferror(file_) != 0;
    const bool close_failed = std::fclose(file_) != 0;
    file_ = nullptr;
    if (failed || close_failed) throw std::runtime_error("error writing " + path_);
  }

 private:
  std::string path_;
  FILE* file_;
};

/// Binary entropy of a cell in nats, eq. (6)'s summand.
double CellEntropyNats(double p) {
  if (p <= 0.0 || p >= 1.0) return 0.0;
  return -p * std::log(p) - (1.0 - p) * std::log(1.0 - p);
}

struct Sample {
  int64_t utime{0};
  int64_t map_seq{-1};
  double entropy_status_nats{kNan};
  double entropy_replica_nats{kNan};
  int64_t replica_seq{-1};
  double known_fraction{kNan};
  double accuracy{kNan};
  double known_fraction_lattice{kNan};
};

struct Map2dCopy {
  int64_t clock_utime{0};  // the run's clock when it was received
  grid_map_t msg;
};

struct PlanCopy {
  int64_t clock_utime{0};
  exploration_status_t msg;
};

/// The ground truth of section 10 on the map lattice (as tools/map_score/map_scorer.cc builds it).
struct Truth {
  GridSpec grid;
  std::vector<uint8_t> occupied;
  std::vector<uint8_t> observable;
};

/// Natural order of prefixes: runs of digits compare as numbers (V2_ before V10_), the rest
/// character by character; a prefix of another comes first ("" first of all).
bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      na.erase(0, std::min(na.find_first_not_of('0'), na.size()));
      nb.erase(0, std::min(nb.find_first_not_of('0'), nb.size()));
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return a.size() - i < b.size() - j;
  return a < b;  // equal up to leading zeros: any fixed order
}

bool IsPrefixText(const std::string& text) {
  return std::all_of(text.begin(), text.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_';
  });
}

/// One vehicle while the log is read.
struct VehicleTrack {
  ReportVehicle info;
  std::vector<std::array<double, 5>> trajectory;  // utime, x, y, z, yaw
  int64_t last_trajectory_utime{std::numeric_limits<int64_t>::min()};
  std::optional<Eigen::Vector3d> last_position_m;
  int64_t final_clock_utime{-1};
};

std::string JoinNames(const std::map<std::string, int64_t>& counts) {
  std::string out;
  for (const auto& [name, count] : counts) {
    if (!out.empty()) out += ", ";
    out += name + " (" + std::to_string(count) + ")";
  }
  return out.empty() ? "none" : out;
}

}  // namespace

std::vector<std::string> VehiclePrefixesOf(const std::vector<std::string>& channels,
                                           const std::string& pose_channel) {
  std::vector<std::string> prefixes;
  for (const std::string& channel : channels) {
    if (pose_channel.empty() || channel.size() < pose_channel.size() ||
        channel.compare(channel.size() - pose_channel.size(), pose_channel.size(), pose_channel) !=
            0) {
      continue;
    }
    const std::string prefix = channel.substr(0, channel.size() - pose_channel.size());
    if (!IsPrefixText(prefix)) continue;
    if (std::find(prefixes.begin(), prefixes.end(), prefix) == prefixes.end()) {
      prefixes.push_back(prefix);
    }
  }
  std::sort(prefixes.begin(), prefixes.end(), NaturalLess);
  if (prefixes.empty()) prefixes.push_back("");
  return prefixes;
}

void ReportExportConfig::Validate() const {
  KESTREL_THROW_UNLESS(!log_path.empty(), "report: log_path is empty, accepted: a file name");
  KESTREL_THROW_UNLESS(!out_dir.empty(), "report: out_dir is empty, accepted: a directory");
  KESTREL_THROW_UNLESS(
      occupied_threshold > 0.0 && occupied_threshold < 1.0,
      "report: occupied_threshold = " << occupied_threshold << ", accepted (0, 1)");
  KESTREL_THROW_UNLESS(
      trajectory_period_s >= 0.0 && std::isfinite(trajectory_period_s),
      "report: trajectory_period_s = " << trajectory_period_s << ", accepted [0, inf)");
  KESTREL_THROW_UNLESS(sensor_range_m > 0.0 && std::isfinite(sensor_range_m),
                       "report: sensor_range_m = " << sensor_range_m << ", accepted (0, inf)");
  KESTREL_THROW_UNLESS(vertical_fov_rad > 0.0 && vertical_fov_rad < M_PI,
                       "report: vertical_fov_rad = " << vertical_fov_rad << ", accepted (0, pi)");
  for (const double t : map2d_times_s) {
    KESTREL_THROW_UNLESS(t >= 0.0 && std::isfinite(t),
                         "report: map2d time " << t << " s, accepted [0, inf)");
  }
  KESTREL_THROW_UNLESS(vehicle_prefixes.size() <= 16,
                       "report: vehicle_prefixes: " << vehicle_prefixes.size()
                                                    << " listed, accepted: 0 (from the log) to 16");
  for (size_t i = 0; i < vehicle_prefixes.size(); ++i) {
    KESTREL_THROW_UNLESS(IsPrefixText(vehicle_prefixes[i]),
                         "report: vehicle_prefixes[" << i << "] = '" << vehicle_prefixes[i]
                                                     << "', accepted: letters, digits and '_'");
    for (size_t j = 0; j < i; ++j) {
      KESTREL_THROW_UNLESS(vehicle_prefixes[i] != vehicle_prefixes[j],
                           "report: vehicle_prefixes[" << j << "] and [" << i
                                                       << "] share the prefix '"
                                                       << vehicle_prefixes[i] << "'");
    }
  }
}

ReportExportSummary ExportReportData(const ReportExportConfig& config) {
  config.Validate();
  ReportExportSummary summary;
  auto warn = [&](const std::string& text) {
    summary.warnings.push_back(text);
    std::fprintf(stderr, "kestrel-report-export: warning: %s\n", text.c_str());
  };

  // Pass 1: which channels the log holds, and whether it ends inside an event.
  std::map<std::string, int64_t> channel_counts;
  std::uintmax_t log_bytes = 0;
  {
    std::error_code ec;
    log_bytes = std::filesystem::file_size(config.log_path, ec);
    if (ec)
      throw std::runtime_error("cannot read the log " + config.log_path + ": " + ec.message());
    lcm::LogFile log(config.log_path, "r");
    if (!log.good()) throw std::runtime_error("cannot open the log " + config.log_path);
    long end = 0;  // just after the last complete event
    while (const lcm::LogEvent* event = log.readNextEvent()) {
      ++channel_counts[event->channel];
      end = std::ftell(log.getFilePtr());
    }
    if (end >= 0 && static_cast<std::uintmax_t>(end) < log_bytes) {
      summary.truncated = true;
      std::ostringstream text;
      text << "the log " << config.log_path << " ends inside an event (" << end << " of "
           << log_bytes << " bytes read): using the events before it";
      warn(text.str());
    }
  }
  auto count_of = [&](const std::string& channel) {
    const auto it = channel_counts.find(channel);
    return it == channel_counts.end() ? int64_t{0} : it->second;
  };
  if (count_of(config.map_channel) == 0) {
    throw std::runtime_error("the log " + config.log_path + " has no " + config.map_channel +
                             " message: cannot rebuild the 3D map (channels in the log: " +
                             JoinNames(channel_counts) + ")");
  }
  const bool have_status = count_of(config.status_channel) > 0;
  if (!have_status) {
    warn("no " + config.status_channel +
         " in the log: sampling at map updates, entropy recomputed from the map only");
  }
  // The vehicles (docs/design.md §7.10): as configured, or from the pose channels in the log.
  std::vector<std::string> prefixes = config.vehicle_prefixes;
  if (prefixes.empty()) {
    std::vector<std::string> names;
    for (const auto& [name, count] : channel_counts) names.push_back(name);
    prefixes = VehiclePrefixesOf(names, config.pose_channel);
  }
  std::vector<VehicleTrack> tracks(prefixes.size());
  std::map<std::string, size_t> pose_vehicle, exploration_vehicle;  // channel -> vehicle
  for (size_t k = 0; k < prefixes.size(); ++k) {
    tracks[k].info.prefix = prefixes[k];
    tracks[k].info.trajectory_file =
        k == 0 ? "trajectory.csv" : "trajectory_" + prefixes[k] + ".csv";
    pose_vehicle[prefixes[k] + config.pose_channel] = k;
    exploration_vehicle[prefixes[k] + config.exploration_channel] = k;
    if (count_of(prefixes[k] + config.pose_channel) == 0) {
      warn("no " + prefixes[k] + config.pose_channel + ": no trajectory");
    }
  }
  if (count_of(prefixes.front() + config.exploration_channel) == 0) {
    warn("no " + prefixes.front() + config.exploration_channel + ": no candidate poses");
  }
  // The 2D maps of the first vehicle's explorer.
  const std::string map2d_prefix = prefixes.front() + config.map2d_prefix;

  std::optional<World> world;
  if (!config.world_path.empty()) world = LoadWorld(config.world_path);

  // Pass 2: everything, in log order.
  lcm::LogFile log(config.log_path, "r");
  if (!log.good()) throw std::runtime_error("cannot open the log " + config.log_path);
  std::unique_ptr<MapReplica> replica;
  std::optional<Truth> truth;
  double p_init = kNan;
  int64_t origin_utime = -1;  // first MAP_STATUS (or first map update)
  int64_t clock_utime = std::numeric_limits<int64_t>::min();
  int64_t first_clock_utime = -1;
  std::vector<Sample> samples;
  std::vector<Map2dCopy> map2d;
  std::vector<PlanCopy> plans;
  std::map<std::string, int64_t> malformed_by_channel;
  std::vector<std::pair<std::string, params_t>> configurations;    // (channel, newest message)
  std::map<std::pair<std::string, int64_t>, size_t> params_index;  // (channel, epoch) -> index

  auto take_sample = [&](Sample s) {
    if (replica != nullptr && replica->current()) {
      const std::vector<float>& p = replica->probabilities();
      double h = 0.0;
      size_t known = 0;
      for (const float v : p) {
        h += CellEntropyNats(static_cast<double>(v));  // eq. (6)
        known += (v < 0.5 * p_init || v > 0.5);
      }
      s.entropy_replica_nats = h;
      s.replica_seq = replica->seq();
      s.known_fraction_lattice = static_cast<double>(known) / static_cast<double>(p.size());
      if (truth.has_value()) {
        const std::vector<double> pd(p.begin(), p.end());
        const MapQuality q = ComputeMapQuality(pd, truth->occupied, truth->observable, p_init);
        s.known_fraction = q.known_fraction;
        s.accuracy = q.accuracy;
      }
    }
    samples.push_back(s);
  };
  auto advance_clock = [&](int64_t utime) {
    clock_utime = std::max(clock_utime, utime);
    if (first_clock_utime < 0) first_clock_utime = utime;
  };

  while (const lcm::LogEvent* event = log.readNextEvent()) {
    ++summary.events;
    const std::string& channel = event->channel;
    const void* data = event->data;
    const size_t size = static_cast<size_t>(event->datalen);
    std::string error;
    auto malformed = [&]() {
      ++summary.malformed;
      if (malformed_by_channel[channel]++ == 0) warn(channel + ": malformed message: " + error);
    };
    if (channel == config.map_channel) {
      map3d_chunk_t chunk;
      if (!GuardedDecode(data, size, &chunk, &error)) {
        malformed();
        continue;
      }
      if (replica == nullptr) {
        const Eigen::Vector3i dims(chunk.dims[0], chunk.dims[1], chunk.dims[2]);
        if (dims.minCoeff() <= 0) {
          throw std::runtime_error(
              "the map in " + config.log_path +
              " is unbounded (a growing map, dims 0): kestrel-report needs a fixed map");
        }
        const Eigen::Vector3d origin(chunk.origin_m[0], chunk.origin_m[1], chunk.origin_m[2]);
        replica = std::make_unique<MapReplica>(origin, chunk.resolution_m, dims, chunk.p_init);
        p_init = chunk.p_init;
        if (world.has_value()) {
          Truth t;
          t.grid = GridSpec{origin, chunk.resolution_m, dims};
          t.occupied = VoxelizeWorld(*world, t.grid);
          const WorldRayCaster caster(*world);
          // As tools/map_score/map_scorer.cc, with the shipped depth camera's rule.
          t.observable = ComputeObservableCells(
                             *world, caster, t.grid,
                             SensorSweep(config.sensor_range_m, config.vertical_fov_rad, false))
                             .observable;
          truth = std::move(t);
        }
      }
      const bool was_current = replica->current();
      const int64_t seq_before = replica->seq();
      if (replica->Apply(chunk, &error)) {
        ++summary.snapshots_chunks;
        const bool completed = replica->current() && (!was_current || replica->seq() != seq_before);
        if (origin_utime < 0 && !have_status && replica->current()) origin_utime = chunk.utime;
        if (!have_status && completed && chunk.chunk_index + 1 == chunk.num_chunks) {
          Sample s;
          s.utime = chunk.utime;
          s.map_seq = chunk.map_seq;
          take_sample(s);
        }
      } else {
        ++summary.map_rejects;
      }
    } else if (channel == config.delta_channel) {
      map3d_delta_t delta;
      if (!GuardedDecode(data, size, &delta, &error)) {
        malformed();
        continue;
      }
      if (replica == nullptr) continue;  // before the first snapshot
      if (replica->Apply(delta, &error)) {
        ++summary.deltas_applied;
        if (!have_status && replica->current()) {
          Sample s;
          s.utime = delta.utime;
          s.map_seq = delta.seq;
          take_sample(s);
        }
      } else {
        ++summary.map_rejects;
      }
    } else if (channel == config.status_channel) {
      map_status_t status;
      if (!GuardedDecode(data, size, &status, &error)) {
        malformed();
        continue;
      }
      ++summary.status_messages;
      advance_clock(status.utime);
      if (origin_utime < 0) origin_utime = status.utime;
      Sample s;
      s.utime = status.utime;
      s.map_seq = status.map_seq;
      s.entropy_status_nats = status.map_entropy_nats;
      take_sample(s);
    } else if (const auto pv = pose_vehicle.find(channel); pv != pose_vehicle.end()) {
      pose_t pose;
      if (!GuardedDecode(data, size, &pose, &error)) {
        malformed();
        continue;
      }
      VehicleTrack& v = tracks[pv->second];
      ++summary.poses;
      ++v.info.poses;
      advance_clock(pose.utime);
      Eigen::Quaterniond q;
      if (!pose.valid || !QuaternionFromWxyz(pose.orientation_wxyz, &q)) continue;
      ++v.info.valid_poses;
      const double period_us = 1e6 * config.trajectory_period_s;
      if (!v.trajectory.empty() &&
          static_cast<double>(pose.utime - v.last_trajectory_utime) < period_us) {
        continue;
      }
      v.last_trajectory_utime = pose.utime;
      v.trajectory.push_back({static_cast<double>(pose.utime), pose.position_m[0],
                              pose.position_m[1], pose.position_m[2], YawOf(q)});
      // The path length along the kept poses: summed over every pose, motion-capture noise
      // (0.5 mm at 100 Hz in simulation) would add about a fifth to it.
      const Eigen::Vector3d p(pose.position_m[0], pose.position_m[1], pose.position_m[2]);
      if (p.allFinite()) {
        if (v.last_position_m.has_value()) v.info.path_length_m += (p - *v.last_position_m).norm();
        v.last_position_m = p;
      }
    } else if (const auto ev = exploration_vehicle.find(channel); ev != exploration_vehicle.end()) {
      PlanCopy plan;
      if (!GuardedDecode(data, size, &plan.msg, &error)) {
        malformed();
        continue;
      }
      plan.clock_utime = std::max(clock_utime, plan.msg.utime);
      VehicleTrack& v = tracks[ev->second];
      ++v.info.plans;
      v.info.final_state = plan.msg.state;
      v.info.final_reason = plan.msg.reason;
      v.final_clock_utime = plan.clock_utime;
      v.info.land_sent = v.info.land_sent || plan.msg.state == exploration_status_t::STATE_DONE;
      if (ev->second == 0) {  // plans.csv, candidates.csv: the first vehicle's
        ++summary.plans;
        plans.push_back(std::move(plan));
      }
    } else if (!config.params_prefix.empty() && channel.rfind(config.params_prefix, 0) == 0) {
      params_t params;
      if (!GuardedDecode(data, size, &params, &error)) {
        malformed();
        continue;
      }
      ++summary.params_messages;
      // The newest message of each life of each publisher: values read after the start are in it.
      const auto [it, inserted] =
          params_index.emplace(std::make_pair(channel, params.epoch), configurations.size());
      if (inserted) {
        configurations.emplace_back(channel, std::move(params));
      } else {
        configurations[it->second].second = std::move(params);
      }
    } else if (channel.rfind(map2d_prefix, 0) == 0) {
      Map2dCopy copy;
      if (!GuardedDecode(data, size, &copy.msg, &error)) {
        malformed();
        continue;
      }
      if (copy.msg.width <= 0 || copy.msg.height <= 0 ||
          static_cast<int64_t>(copy.msg.values.size()) !=
              static_cast<int64_t>(copy.msg.width) * copy.msg.height) {
        error = "size " + std::to_string(copy.msg.width) + " x " + std::to_string(copy.msg.height) +
                " does not match " + std::to_string(copy.msg.values.size()) + " values";
        malformed();
        continue;
      }
      ++summary.map2d_messages;
      copy.clock_utime = std::max(clock_utime, copy.msg.utime);
      map2d.push_back(std::move(copy));
    }
  }
  if (replica == nullptr || !replica->current()) {
    throw std::runtime_error("the log " + config.log_path + " holds no complete " +
                             config.map_channel + " snapshot that the map can be rebuilt from");
  }
  // The map at the end of the log, when it changed after the last sample (the mapper's final
  // updates): one more row, without a MAP_STATUS entropy.
  if (samples.empty() || samples.back().replica_seq != replica->seq()) {
    Sample s;
    s.utime = std::max(replica->utime(), samples.empty() ? replica->utime() : samples.back().utime);
    s.map_seq = replica->seq();
    take_sample(s);
  }
  if (summary.map_rejects > 0) {
    warn(std::to_string(summary.map_rejects) +
         " map chunks or deltas did not fit the map copy (lost messages): the copy waited for "
         "the next snapshot");
  }
  if (origin_utime < 0) origin_utime = first_clock_utime >= 0 ? first_clock_utime : 0;
  const int64_t end_utime = clock_utime == std::numeric_limits<int64_t>::min()
                                ? replica->utime()
                                : std::max(clock_utime, replica->utime());
  summary.duration_s = SecondsBetween(end_utime, origin_utime);
  summary.samples = samples.size();

  std::error_code ec;
  std::filesystem::create_directories(config.out_dir, ec);
  if (ec) throw std::runtime_error("cannot create " + config.out_dir + ": " + ec.message());
  const std::string dir = config.out_dir + "/";

  {  // timeseries.csv
    CsvFile f(dir + "timeseries.csv");
    std::fprintf(f.get(),
                 "time_s,utime,map_seq,entropy_nats,entropy_replica_nats,replica_seq,"
                 "known_fraction,accuracy,known_fraction_lattice\n");
    for (const Sample& s : samples) {
      std::fprintf(f.get(), "%.3f,%lld,%lld,%.6f,%.6f,%lld,%.6f,%.6f,%.6f\n",
                   SecondsBetween(s.utime, origin_utime), static_cast<long long>(s.utime),
                   static_cast<long long>(s.map_seq), s.entropy_status_nats, s.entropy_replica_nats,
                   static_cast<long long>(s.replica_seq), s.known_fraction, s.accuracy,
                   s.known_fraction_lattice);
    }
    f.Close();
  }
  for (VehicleTrack& v : tracks) {  // trajectory.csv, trajectory_<prefix>.csv
    CsvFile f(dir + v.info.trajectory_file);
    std::fprintf(f.get(), "time_s,x_m,y_m,z_m,yaw_rad\n");
    for (const auto& row : v.trajectory) {
      std::fprintf(f.get(), "%.3f,%.4f,%.4f,%.4f,%.4f\n",
                   SecondsBetween(static_cast<int64_t>(row[0]), origin_utime), row[1], row[2],
                   row[3], row[4]);
    }
    f.Close();
    v.info.final_time_s =
        v.final_clock_utime < 0 ? kNan : SecondsBetween(v.final_clock_utime, origin_utime);
    summary.vehicles.push_back(v.info);
  }
  {  // vehicles.csv
    CsvFile f(dir + "vehicles.csv");
    std::fprintf(f.get(),
                 "vehicle,prefix,trajectory_file,poses,valid_poses,path_length_m,plans,"
                 "final_state,final_time_s,land_sent,final_reason,final_state_name\n");
    for (size_t k = 0; k < summary.vehicles.size(); ++k) {
      const ReportVehicle& v = summary.vehicles[k];
      // The state's name from the explorer's table (exploration/explorer_state.h), "" if none.
      const std::string state_name = v.final_state < 0 ? "" : ExplorerStateName(v.final_state);
      std::fprintf(f.get(), "%zu,%s,%s,%lld,%lld,%.4f,%lld,%d,%.3f,%d,%s,%s\n", k,
                   CsvField(v.prefix).c_str(), CsvField(v.trajectory_file).c_str(),
                   static_cast<long long>(v.poses), static_cast<long long>(v.valid_poses),
                   v.path_length_m, static_cast<long long>(v.plans), v.final_state, v.final_time_s,
                   v.land_sent ? 1 : 0, CsvField(v.final_reason).c_str(),
                   CsvField(state_name).c_str());
    }
    f.Close();
  }
  {  // plans.csv, candidates.csv
    CsvFile fp(dir + "plans.csv");
    CsvFile fc(dir + "candidates.csv");
    std::fprintf(fp.get(),
                 "plan,time_s,mode,state,chosen_index,goal_x_m,goal_y_m,goal_z_m,goal_yaw_rad,"
                 "best_unweighted_gain_nats,num_candidates,state_name\n");
    std::fprintf(fc.get(),
                 "plan,time_s,index,x_m,y_m,z_m,yaw_rad,gain_nats,distance_m,bump,objective,"
                 "chosen\n");
    for (size_t k = 0; k < plans.size(); ++k) {
      const exploration_status_t& m = plans[k].msg;
      const double t = SecondsBetween(plans[k].clock_utime, origin_utime);
      std::fprintf(fp.get(), "%zu,%.3f,%s,%d,%d,%.4f,%.4f,%.4f,%.4f,%.6f,%d,%s\n", k, t,
                   m.mode.c_str(), m.state, m.chosen_index, m.goal_position_m[0],
                   m.goal_position_m[1], m.goal_position_m[2], m.goal_yaw_rad,
                   m.best_unweighted_gain_nats, m.num_candidates,
                   CsvField(ExplorerStateName(m.state)).c_str());
      for (size_t i = 0; i < m.candidates.size(); ++i) {
        const candidate_t& c = m.candidates[i];
        std::fprintf(fc.get(), "%zu,%.3f,%zu,%.4f,%.4f,%.4f,%.4f,%.6f,%.4f,%.6f,%.6f,%d\n", k, t, i,
                     c.position_m[0], c.position_m[1], c.position_m[2], c.yaw_rad, c.gain_nats,
                     c.distance_m, c.bump, c.objective,
                     static_cast<int>(static_cast<int>(i) == m.chosen_index));
      }
    }
    fp.Close();
    fc.Close();
  }
  {  // The newest 2D map of each name received by each requested time (clock <= t).
    std::vector<double> times = config.map2d_times_s;
    if (times.empty()) {  // half way from the first 2D map to the end, and the end
      const double end_s = std::max(0.0, summary.duration_s);
      double first_s = 0.0;
      if (!map2d.empty()) {
        first_s = std::clamp(SecondsBetween(map2d.front().clock_utime, origin_utime), 0.0, end_s);
      }
      times = {std::ceil(0.5 * (first_s + end_s)), std::floor(end_s)};
      if (times[0] >= times[1]) times = {times[1]};
    }
    std::vector<std::string> names;
    for (const Map2dCopy& m : map2d) {
      if (std::find(names.begin(), names.end(), m.msg.name) == names.end()) {
        names.push_back(m.msg.name);
      }
    }
    std::sort(names.begin(), names.end());
    CsvFile index(dir + "map2d_index.csv");
    std::fprintf(index.get(),
                 "k,request_time_s,name,time_s,origin_x_m,origin_y_m,resolution_m,width,height,"
                 "height_m,plan,file\n");
    for (size_t k = 0; k < times.size(); ++k) {
      const int64_t limit = origin_utime + static_cast<int64_t>(std::llround(times[k] * 1e6));
      int64_t plan = -1;
      for (size_t i = 0; i < plans.size(); ++i) {
        if (plans[i].clock_utime <= limit) plan = static_cast<int64_t>(i);
      }
      for (const std::string& name : names) {
        const Map2dCopy* newest = nullptr;
        for (const Map2dCopy& m : map2d) {
          if (m.msg.name == name && m.clock_utime <= limit) newest = &m;
        }
        if (newest == nullptr) continue;
        std::string safe = name;
        for (char& ch : safe) {
          if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
        }
        const std::string file = "map2d_" + std::to_string(k) + "_" + safe + ".csv";
        const grid_map_t& g = newest->msg;
        std::fprintf(index.get(), "%zu,%.3f,%s,%.3f,%.4f,%.4f,%.4f,%d,%d,%.4f,%lld,%s\n", k,
                     times[k], safe.c_str(), SecondsBetween(newest->clock_utime, origin_utime),
                     g.origin_m[0], g.origin_m[1], g.resolution_m, g.width, g.height, g.height_m,
                     static_cast<long long>(plan), file.c_str());
        CsvFile f(dir + file);
        for (int y = 0; y < g.height; ++y) {
          for (int x = 0; x < g.width; ++x) {
            std::fprintf(f.get(), x == 0 ? "%.6g" : ",%.6g",
                         static_cast<double>(g.values[static_cast<size_t>(y) * g.width + x]));
          }
          std::fputc('\n', f.get());
        }
        f.Close();
      }
    }
    index.Close();
  }
  {  // occupied.csv: the final map
    CsvFile f(dir + "occupied.csv");
    std::fprintf(f.get(), "x_m,y_m,z_m,p\n");
    const Eigen::Vector3i& d = replica->dims();
    const double a = replica->resolution_m();
    const Eigen::Vector3d& o = replica->origin_m();
    for (int z = 0; z < d.z(); ++z) {
      for (int y = 0; y < d.y(); ++y) {
        for (int x = 0; x < d.x(); ++x) {
          const float p = replica->At(x, y, z);
          if (!(static_cast<double>(p) > config.occupied_threshold)) continue;
          ++summary.occupied_cells;
          // p with a float's full precision (%.9g): at 4 decimals a cell just above the
          // threshold read back as the threshold itself.
          std::fprintf(f.get(), "%.4f,%.4f,%.4f,%.9g\n", o.x() + (x + 0.5) * a,
                       o.y() + (y + 0.5) * a, o.z() + (z + 0.5) * a, static_cast<double>(p));
        }
      }
    }
    f.Close();
  }
  {  // truth.csv
    CsvFile f(dir + "truth.csv");
    std::fprintf(f.get(), "x_m,y_m,z_m\n");
    if (truth.has_value()) {
      for (size_t i = 0; i < truth->occupied.size(); ++i) {
        if (!truth->occupied[i]) continue;
        ++summary.truth_cells;
        const Eigen::Vector3d c = truth->grid.BoxOf(truth->grid.CellOf(i)).center();
        std::fprintf(f.get(), "%.4f,%.4f,%.4f\n", c.x(), c.y(), c.z());
      }
    }
    f.Close();
  }
  {  // config_processes.csv, config.csv
    CsvFile fp(dir + "config_processes.csv");
    CsvFile fv(dir + "config.csv");
    std::fprintf(fp.get(),
                 "channel,process,host,pid,epoch,run_id,config_file,command_line,utime\n");
    std::fprintf(fv.get(), "channel,process,epoch,key,value,source,file\n");
    for (const auto& [channel, m] : configurations) {
      std::string command_line;
      for (const std::string& a : m.args) command_line += (command_line.empty() ? "" : " ") + a;
      std::fprintf(fp.get(), "%s,%s,%s,%d,%lld,%s,%s,%s,%lld\n", CsvField(channel).c_str(),
                   CsvField(m.process).c_str(), CsvField(m.host).c_str(), m.pid,
                   static_cast<long long>(m.epoch), CsvField(m.run_id).c_str(),
                   CsvField(m.config_file).c_str(), CsvField(command_line).c_str(),
                   static_cast<long long>(m.utime));
      for (const param_t& p : m.params) {
        std::fprintf(fv.get(), "%s,%s,%lld,%s,%s,%s,%s\n", CsvField(channel).c_str(),
                     CsvField(m.process).c_str(), static_cast<long long>(m.epoch),
                     CsvField(p.key).c_str(), CsvField(p.value).c_str(), ParamSourceName(p.source),
                     CsvField(p.file).c_str());
      }
    }
    fp.Close();
    fv.Close();
    summary.configurations = configurations.size();
    if (configurations.empty()) {
      warn("no " + config.params_prefix +
           "* message in the log: the processes' configuration is unknown (recorded by processes "
           "built after it was added; kestrel-cmd params asks running ones again)");
    }
  }
  {  // meta.csv
    CsvFile f(dir + "meta.csv");
    const Eigen::Vector3d& o = replica->origin_m();
    const Eigen::Vector3i& d = replica->dims();
    std::fprintf(f.get(), "key,value\n");
    std::fprintf(f.get(), "log,%s\n", config.log_path.c_str());
    std::fprintf(f.get(), "world,%s\n", config.world_path.c_str());
    std::fprintf(f.get(), "origin_x_m,%.6f\norigin_y_m,%.6f\norigin_z_m,%.6f\n", o.x(), o.y(),
                 o.z());
    std::fprintf(f.get(), "resolution_m,%.6f\n", replica->resolution_m());
    std::fprintf(f.get(), "dims_x,%d\ndims_y,%d\ndims_z,%d\n", d.x(), d.y(), d.z());
    std::fprintf(f.get(), "p_init,%.6f\n", p_init);
    std::fprintf(f.get(), "occupied_threshold,%.6f\n", config.occupied_threshold);
    std::fprintf(f.get(), "origin_utime,%lld\n", static_cast<long long>(origin_utime));
    std::fprintf(f.get(), "duration_s,%.3f\n", summary.duration_s);
    std::fprintf(f.get(), "final_map_seq,%lld\n", static_cast<long long>(replica->seq()));
    std::fprintf(f.get(), "events,%lld\n", static_cast<long long>(summary.events));
    std::fprintf(f.get(), "malformed,%lld\n", static_cast<long long>(summary.malformed));
    std::fprintf(f.get(), "map_rejects,%lld\n", static_cast<long long>(summary.map_rejects));
    std::fprintf(f.get(), "truncated,%d\n", summary.truncated ? 1 : 0);
    std::fprintf(f.get(), "samples,%zu\n", summary.samples);
    std::fprintf(f.get(), "occupied_cells,%zu\n", summary.occupied_cells);
    std::fprintf(f.get(), "truth_cells,%zu\n", summary.truth_cells);
    std::fprintf(f.get(), "plans,%lld\n", static_cast<long long>(summary.plans));
    std::fprintf(f.get(), "map2d_messages,%lld\n", static_cast<long long>(summary.map2d_messages));
    std::fprintf(f.get(), "configurations,%zu\n", summary.configurations);
    std::fprintf(f.get(), "vehicles,%zu\n", summary.vehicles.size());
    f.Close();
  }
  return summary;
}

}  // namespace kestrel

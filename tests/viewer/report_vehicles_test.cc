// kestrel-report's exporter (viewer/report/report_export.h) with several vehicles
// (docs/design.md §7.10), on a short two-vehicle mission (V1_, V2_) recorded and exported by the
// ctest fixture report_fixture_two_vehicles (tests/viewer/report_fixture_two_vehicles.sh): the
// vehicles found in the log, each one's path and statuses against its own messages decoded here,
// nothing of one vehicle in the other's files; and how prefixes are found and checked.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Core>
#include <lcm/lcm-cpp.hpp>

#include "common/lcm_decode.h"
#include "exploration/explorer_state.h"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/pose_t.hpp"
#include "viewer/report/report_export.h"

namespace kestrel {
namespace {

const std::string kFixtureDir = KESTREL_REPORT_TWO_VEHICLES_DIR;
const std::string kLog = kFixtureDir + "/two.lcmlog";
const std::string kExport = kFixtureDir + "/export";
const std::vector<std::string> kPrefixes{"V1_", "V2_"};

/// A CSV file as rows of named fields (RFC 4180 quotes: "a, b" and doubled quotes).
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  [[nodiscard]] size_t Column(const std::string& name) const {
    for (size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return i;
    }
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
  [[nodiscard]] const std::string& Text(size_t row, const std::string& name) const {
    return rows.at(row).at(Column(name));
  }
  [[nodiscard]] double Number(size_t row, const std::string& name) const {
    return std::stod(Text(row, name));
  }
};

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

Csv ReadCsv(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  Csv csv;
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    if (first) {
      csv.header = SplitCsvLine(line);
      first = false;
    } else {
      csv.rows.push_back(SplitCsvLine(line));
    }
  }
  return csv;
}

/// Every message on `channel` in the log, decoded here.
template <typename Message>
std::vector<Message> ReadChannel(const std::string& channel) {
  lcm::LogFile log(kLog, "r");
  EXPECT_TRUE(log.good()) << kLog;
  std::vector<Message> out;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    if (e->channel != channel) continue;
    Message m;
    std::string error;
    EXPECT_TRUE(GuardedDecode(e->data, static_cast<size_t>(e->datalen), &m, &error)) << error;
    out.push_back(m);
  }
  return out;
}

Eigen::Vector3d PositionOf(const pose_t& m) {
  return {m.position_m[0], m.position_m[1], m.position_m[2]};
}

/// The positions of the valid poses on `channel`, by utime.
std::map<int64_t, Eigen::Vector3d> ValidPoses(const std::string& channel) {
  std::map<int64_t, Eigen::Vector3d> out;
  for (const pose_t& m : ReadChannel<pose_t>(channel)) {
    if (m.valid) out[m.utime] = PositionOf(m);
  }
  return out;
}

// Both vehicles are found from their V1_/V2_POSE_VICON channels, in order, each with its own
// trajectory file; the first one's is trajectory.csv (as in a one-vehicle run).
TEST(ReportVehicles, TwoVehiclesAreFoundInTheLog) {
  const Csv v = ReadCsv(kExport + "/vehicles.csv");
  ASSERT_EQ(v.rows.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(v.Text(k, "vehicle"), std::to_string(k));
    EXPECT_EQ(v.Text(k, "prefix"), kPrefixes[k]);
    EXPECT_TRUE(std::filesystem::exists(kExport + "/" + v.Text(k, "trajectory_file")));
  }
  EXPECT_EQ(v.Text(0, "trajectory_file"), "trajectory.csv");
  EXPECT_EQ(v.Text(1, "trajectory_file"), "trajectory_V2_.csv");
  std::ifstream meta(kExport + "/meta.csv");
  bool found = false;
  for (std::string line; std::getline(meta, line);) found = found || line == "vehicles,2";
  EXPECT_TRUE(found) << "meta.csv has no vehicles,2";
}

/// The path length along the valid poses kept one per `period_us` (the first, then each one at
/// least that long after the last kept), as the exporter documents it.
double KeptPathLength(const std::vector<pose_t>& poses, int64_t period_us) {
  double length = 0.0;
  std::optional<Eigen::Vector3d> last;
  int64_t last_utime = 0;
  for (const pose_t& m : poses) {
    if (!m.valid) continue;
    if (last && m.utime - last_utime < period_us) continue;
    if (last) length += (PositionOf(m) - *last).norm();
    last = PositionOf(m);
    last_utime = m.utime;
  }
  return length;
}

/// The true path length kestrel-mission printed for a vehicle ("vehicle V1_: ... path 8.58 m"),
/// or -1 when its summary has no such line.
double MissionPathLength(const std::string& prefix) {
  std::ifstream in(kFixtureDir + "/two.txt");
  const std::string start = "vehicle " + prefix + ": ";
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(start, 0) != 0) continue;
    const size_t at = line.find(", path ");
    if (at != std::string::npos) return std::stod(line.substr(at + 7));
  }
  return -1.0;
}

// Each vehicle's path length is that of its own valid poses in the log, one per 0.1 s, close to
// the simulator's true path that kestrel-mission printed; the two differ (they flew apart); pose
// counts are each vehicle's own.
TEST(ReportVehicles, PathLengthsMatchTheLogsPoses) {
  const Csv v = ReadCsv(kExport + "/vehicles.csv");
  ASSERT_EQ(v.rows.size(), 2u);
  std::vector<double> lengths;
  for (size_t k = 0; k < 2; ++k) {
    const std::vector<pose_t> poses = ReadChannel<pose_t>(kPrefixes[k] + "POSE_VICON");
    ASSERT_GT(poses.size(), 100u);
    int64_t valid = 0;
    for (const pose_t& m : poses) valid += m.valid ? 1 : 0;
    const double length = KeptPathLength(poses, 100000);
    EXPECT_EQ(v.Number(k, "poses"), static_cast<double>(poses.size())) << kPrefixes[k];
    EXPECT_EQ(v.Number(k, "valid_poses"), static_cast<double>(valid)) << kPrefixes[k];
    EXPECT_GT(length, 2.0) << kPrefixes[k];
    EXPECT_NEAR(v.Number(k, "path_length_m"), length, 1e-3) << kPrefixes[k];
    const double truth = MissionPathLength(kPrefixes[k]);
    if (truth > 0) {
      EXPECT_NEAR(length, truth, 0.03 * truth) << kPrefixes[k] << ": the simulator's true path";
    } else {
      std::printf("(two.txt has no path for %s: not compared with the true path)\n",
                  kPrefixes[k].c_str());
    }
    lengths.push_back(length);
  }
  EXPECT_GT(std::abs(lengths[0] - lengths[1]), 1e-3) << "the two paths have the same length";
}

// Every row of a vehicle's trajectory file is one of its own valid poses, at that pose's time,
// and not where the other vehicle was at that time: no pose crossed over.
TEST(ReportVehicles, EachTrajectoryHoldsItsOwnVehiclesPoses) {
  const Csv v = ReadCsv(kExport + "/vehicles.csv");
  ASSERT_EQ(v.rows.size(), 2u);
  const std::map<int64_t, Eigen::Vector3d> poses[2] = {ValidPoses("V1_POSE_VICON"),
                                                       ValidPoses("V2_POSE_VICON")};
  // Times in the files are seconds since meta.csv's origin_utime, to 1 ms.
  int64_t origin_utime = -1;
  std::ifstream meta(kExport + "/meta.csv");
  for (std::string line; std::getline(meta, line);) {
    if (line.rfind("origin_utime,", 0) == 0) origin_utime = std::stoll(line.substr(13));
  }
  ASSERT_GT(origin_utime, 0);
  for (size_t k = 0; k < 2; ++k) {
    const Csv t = ReadCsv(kExport + "/" + v.Text(k, "trajectory_file"));
    ASSERT_GT(t.rows.size(), 50u) << kPrefixes[k];
    size_t own = 0;
    for (size_t i = 0; i < t.rows.size(); ++i) {
      const int64_t utime =
          origin_utime + static_cast<int64_t>(std::llround(t.Number(i, "time_s") * 1e6));
      const Eigen::Vector3d p(t.Number(i, "x_m"), t.Number(i, "y_m"), t.Number(i, "z_m"));
      // The pose of this vehicle at that time (the file rounds times to 1 ms).
      const auto it = poses[k].lower_bound(utime - 1000);
      ASSERT_NE(it, poses[k].end());
      ASSERT_LE(it->first, utime + 1000) << kPrefixes[k] << " row " << i;
      own += (it->second - p).norm() < 1e-3;
      const auto other = poses[1 - k].lower_bound(utime - 1000);
      if (other != poses[1 - k].end() && other->first <= utime + 1000) {
        EXPECT_GT((other->second - p).norm(), 0.3) << kPrefixes[k] << " row " << i;
      }
    }
    EXPECT_EQ(own, t.rows.size()) << kPrefixes[k];
  }
}

// Each vehicle's plans and last status are those of its own EXPLORATION_STATUS; plans.csv and
// candidates.csv hold the first vehicle's; the 2D maps are the first vehicle's.
TEST(ReportVehicles, StatusesAreEachVehiclesOwn) {
  const Csv v = ReadCsv(kExport + "/vehicles.csv");
  ASSERT_EQ(v.rows.size(), 2u);
  std::vector<exploration_status_t> statuses[2];
  for (size_t k = 0; k < 2; ++k) {
    statuses[k] = ReadChannel<exploration_status_t>(kPrefixes[k] + "EXPLORATION_STATUS");
    ASSERT_GE(statuses[k].size(), 2u) << kPrefixes[k];
    EXPECT_EQ(v.Number(k, "plans"), static_cast<double>(statuses[k].size())) << kPrefixes[k];
    EXPECT_EQ(v.Number(k, "final_state"), static_cast<double>(statuses[k].back().state));
    EXPECT_EQ(v.Text(k, "final_state_name"), ExplorerStateName(statuses[k].back().state));
    EXPECT_EQ(v.Text(k, "final_reason"), statuses[k].back().reason);
    bool done = false;
    for (const auto& s : statuses[k]) done = done || s.state == exploration_status_t::STATE_DONE;
    EXPECT_EQ(v.Text(k, "land_sent"), done ? "1" : "0");
  }
  const Csv plans = ReadCsv(kExport + "/plans.csv");
  ASSERT_EQ(plans.rows.size(), statuses[0].size());
  const Csv candidates = ReadCsv(kExport + "/candidates.csv");
  size_t total = 0;
  for (const auto& s : statuses[0]) total += s.candidates.size();
  EXPECT_EQ(candidates.rows.size(), total);
  for (size_t i = 0; i < plans.rows.size(); ++i) {
    EXPECT_NEAR(plans.Number(i, "goal_x_m"), statuses[0][i].goal_position_m[0], 1e-4);
  }
  const Csv index = ReadCsv(kExport + "/map2d_index.csv");
  EXPECT_FALSE(index.rows.empty()) << "no 2D map kept from V1_MAP2D_*";
}

// Prefixes come from the channels ending in POSE_VICON: letters, digits and '_' only, in natural
// order; none: one vehicle without a prefix.
TEST(ReportVehicles, PrefixesAreFoundFromThePoseChannels) {
  EXPECT_EQ(VehiclePrefixesOf({"MAP3D", "POSE_VICON", "TRAJECTORY"}, "POSE_VICON"),
            std::vector<std::string>{""});
  EXPECT_EQ(VehiclePrefixesOf({"V10_POSE_VICON", "MAP3D", "V2_POSE_VICON", "X-Y_POSE_VICON",
                               "V2_SIM_TRUTH", "V1_POSE_VICONS"},
                              "POSE_VICON"),
            (std::vector<std::string>{"V2_", "V10_"}));
  EXPECT_EQ(VehiclePrefixesOf({"V2_POSE_VICON", "POSE_VICON", "V1_POSE_VICON"}, "POSE_VICON"),
            (std::vector<std::string>{"", "V1_", "V2_"}));
  EXPECT_EQ(VehiclePrefixesOf({}, "POSE_VICON"), std::vector<std::string>{""});
}

// Named prefixes replace the search: V2_ alone is then the run's first (only) vehicle; a bad or
// repeated prefix is refused, naming it.
TEST(ReportVehicles, NamedPrefixesAreUsedAndChecked) {
  const std::string out =
      ::testing::TempDir() + "kestrel_report_vehicles_" + std::to_string(::getpid());
  std::filesystem::remove_all(out);
  ReportExportConfig c;
  c.log_path = kLog;
  c.out_dir = out;
  c.vehicle_prefixes = {"V2_"};
  const ReportExportSummary s = ExportReportData(c);
  ASSERT_EQ(s.vehicles.size(), 1u);
  EXPECT_EQ(s.vehicles[0].prefix, "V2_");
  EXPECT_EQ(s.vehicles[0].trajectory_file, "trajectory.csv");
  const Csv all = ReadCsv(kExport + "/vehicles.csv");
  EXPECT_NEAR(s.vehicles[0].path_length_m, all.Number(1, "path_length_m"), 1e-3);
  EXPECT_EQ(static_cast<double>(s.plans), all.Number(1, "plans"));
  std::filesystem::remove_all(out);

  c.vehicle_prefixes = {"V1_", "V1_"};
  try {
    c.Validate();
    ADD_FAILURE() << "a repeated prefix was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("share the prefix 'V1_'"), std::string::npos) << e.what();
  }
  c.vehicle_prefixes = {"V1.*"};
  try {
    c.Validate();
    ADD_FAILURE() << "a bad prefix was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("vehicle_prefixes[0] = 'V1.*'"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace kestrel

// Tests of kestrel-report's exporter (viewer/report/report_export.h) on short recorded missions
// made and exported by the ctest fixture report_fixture_runs (tests/viewer/report_fixture.sh,
// kestrel-report-export --times 25,39 with the world) and in-process: the CSV numbers
// against values computed independently (the MAP_STATUS messages decoded here, the mission's own
// known-fraction series and MapScorer, the logic of kestrel-map-score), and bad input.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>
#include <lcm/lcm-cpp.hpp>

#include "common/lcm_decode.h"
#include "kestrel/exploration_status_t.hpp"
#include "kestrel/grid_map_t.hpp"
#include "kestrel/map_status_t.hpp"
#include "kestrel/params_t.hpp"
#include "mapping/map_file.h"
#include "sim/world.h"
#include "sim/world_ray_caster.h"
#include "tools/map_score/map_scorer.h"
#include "viewer/report/report_export.h"

namespace kestrel {
namespace {

const std::string kFixtureDir = KESTREL_REPORT_FIXTURE_DIR;
const std::string kSourceDir = KESTREL_SOURCE_DIR;
const std::string kLog = kFixtureDir + "/combined.lcmlog";
const std::string kWorld = kSourceDir + "/config/worlds/lasr.yaml";

/// A CSV file as rows of named fields.
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
  [[nodiscard]] double Number(size_t row, const std::string& name) const {
    return std::stod(rows.at(row).at(Column(name)));
  }
};

Csv ReadCsv(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  Csv csv;
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream s(line);
    std::string field;
    while (std::getline(s, field, ',')) fields.push_back(field);
    if (first) {
      csv.header = fields;
      first = false;
    } else {
      csv.rows.push_back(fields);
    }
  }
  return csv;
}

/// A scratch directory for one test, removed at the end (per process: other build trees may run
/// the same tests at the same time).
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name)
      : path_(::testing::TempDir() + "kestrel_report_" + name + "_" + std::to_string(::getpid())) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// The fixture's combined-mode run exported with the world by kestrel-report-export (in
/// report_fixture.sh, once for all the cases) into `*out_dir`; returns its meta.csv.
Csv ExportFixture(std::string* out_dir) {
  *out_dir = kFixtureDir + "/export";
  return ReadCsv(*out_dir + "/meta.csv");
}

/// A value of meta.csv.
double Meta(const Csv& meta, const std::string& key) {
  for (const auto& row : meta.rows) {
    if (row.at(0) == key) return std::stod(row.at(1));
  }
  ADD_FAILURE() << "no " << key << " in meta.csv";
  return 0.0;
}

/// Every message on `channel` in the log, decoded here.
template <typename Message>
std::vector<Message> ReadChannel(const std::string& log_path, const std::string& channel) {
  lcm::LogFile log(log_path, "r");
  EXPECT_TRUE(log.good());
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

// The entropy column is the mapper's MAP_STATUS, one row per message, times from the first.
TEST(ReportExport, EntropyColumnIsTheMapStatusSeries) {
  std::string dir;
  ExportFixture(&dir);
  const auto statuses = ReadChannel<map_status_t>(kLog, "MAP_STATUS");
  ASSERT_GE(statuses.size(), 35u);
  const Csv ts = ReadCsv(dir + "/timeseries.csv");
  ASSERT_GE(ts.rows.size(), statuses.size());
  for (size_t i = 0; i < statuses.size(); ++i) {
    EXPECT_NEAR(ts.Number(i, "entropy_nats"), statuses[i].map_entropy_nats,
                1e-9 * statuses[i].map_entropy_nats);
    EXPECT_NEAR(ts.Number(i, "time_s"), 1e-6 * (statuses[i].utime - statuses[0].utime), 1e-3);
    EXPECT_EQ(static_cast<int64_t>(ts.Number(i, "map_seq")), statuses[i].map_seq);
  }
}

// The map rebuilt from MAP3D/MAP3D_DELTA has the mapper's entropy (eq. 6) whenever it holds the
// same updates: the replica is the mapper's map.
TEST(ReportExport, RebuiltMapHasTheMappersEntropy) {
  std::string dir;
  ExportFixture(&dir);
  const Csv ts = ReadCsv(dir + "/timeseries.csv");
  int matched = 0;
  for (size_t i = 0; i < ts.rows.size(); ++i) {
    if (std::isnan(ts.Number(i, "entropy_nats"))) continue;
    if (ts.Number(i, "replica_seq") != ts.Number(i, "map_seq")) continue;
    ++matched;
    EXPECT_NEAR(ts.Number(i, "entropy_replica_nats"), ts.Number(i, "entropy_nats"),
                1e-8 * ts.Number(i, "entropy_nats"))
        << "row " << i;
  }
  EXPECT_GE(matched, 30);
}

// Known fraction over time equals the mission's own series (MapScorer on the mapper's map, every
// 5 s) at the same times, and the last row is close to MapScorer on the final map file.
TEST(ReportExport, KnownFractionMatchesTheMapScorer) {
  std::string dir;
  ExportFixture(&dir);
  const Csv ts = ReadCsv(dir + "/timeseries.csv");
  const Csv mission = ReadCsv(kFixtureDir + "/combined.csv");
  int compared = 0;
  for (size_t m = 0; m < mission.rows.size(); ++m) {
    const double t = mission.Number(m, "time_s");
    for (size_t i = 0; i < ts.rows.size(); ++i) {
      if (std::abs(ts.Number(i, "time_s") - t) > 1e-3 || t < 1.0) continue;
      ++compared;
      // The mission prints 6 significant digits.
      EXPECT_NEAR(ts.Number(i, "known_fraction"), mission.Number(m, "known_fraction"), 2e-6)
          << "t = " << t;
      EXPECT_NEAR(ts.Number(i, "accuracy"), mission.Number(m, "accuracy"), 2e-6) << "t = " << t;
    }
  }
  EXPECT_GE(compared, 6);

  // The final map file (the mapper's last updates may follow the last published delta).
  const World world = LoadWorld(kWorld);
  const auto loaded = LoadDenseMap(kFixtureDir + "/combined.kmap");
  const DenseGrid& g = loaded.map->grid();
  const GridSpec grid{g.geometry().origin_m(), g.geometry().resolution_m(),
                      Eigen::Vector3i(g.dims().x, g.dims().y, g.dims().z)};
  const WorldRayCaster caster(world);
  const MapScorer scorer(world, caster, grid, 4.0, 45.0 * M_PI / 180.0);
  const double p_init = loaded.map->updater().ProbabilityOf(g.initial_value());
  const MapQuality q =
      scorer.Score([&](const CellIndex& c) { return loaded.map->ProbabilityAt(c); }, p_init);
  const double last = ts.Number(ts.rows.size() - 1, "known_fraction");
  const double last_t = ts.Number(ts.rows.size() - 1, "time_s");
  EXPECT_GT(q.known_fraction, 0.2);
  // kestrel-map-score --unknown-bin-m: the observable cells that are not known, counted by column
  // and by layer, are exactly those the score did not count as known.
  const MapScorer::UnknownCells u =
      scorer.Unknown([&](const CellIndex& c) { return loaded.map->ProbabilityAt(c); }, p_init, 0.5);
  size_t by_bin = 0, by_layer = 0;
  for (const size_t n : u.per_bin) by_bin += n;
  for (const size_t n : u.per_layer) by_layer += n;
  EXPECT_EQ(u.never_updated + u.updated, q.observable_cells - q.known_cells);
  EXPECT_EQ(by_bin, q.observable_cells - q.known_cells);
  EXPECT_EQ(by_layer, q.observable_cells - q.known_cells);
  EXPECT_GT(u.never_updated, 0u);
  EXPECT_GT(u.updated, 0u);
  // The last row is the map at the last published delta: no less known than the mission's last
  // 5 s sample before it, and no more than the final map (which holds the later updates; how
  // many depends on the flight, 0.1-0.8 points here).
  double before = 0.0;
  for (size_t m = 0; m < mission.rows.size(); ++m) {
    if (mission.Number(m, "time_s") <= last_t) before = mission.Number(m, "known_fraction");
  }
  EXPECT_GE(last, before - 1e-3) << "last row at t = " << last_t;
  EXPECT_LE(last, q.known_fraction + 1e-3);
  EXPECT_NEAR(last, q.known_fraction, 0.02);
}

// occupied.csv holds the final map's cells above the threshold: nearly the same cells as the
// final map file (which may hold a few later updates), at cell centres of the lattice.
TEST(ReportExport, OccupiedCellsAreTheFinalMapsCells) {
  std::string dir;
  const Csv meta = ExportFixture(&dir);
  const auto loaded = LoadDenseMap(kFixtureDir + "/combined.kmap");
  const DenseGrid& g = loaded.map->grid();
  const double a = g.geometry().resolution_m();
  const Eigen::Vector3d o = g.geometry().origin_m();
  const Csv occ = ReadCsv(dir + "/occupied.csv");
  ASSERT_EQ(static_cast<double>(occ.rows.size()), Meta(meta, "occupied_cells"));
  ASSERT_GT(occ.rows.size(), 1000u);
  size_t agree = 0;
  for (size_t i = 0; i < occ.rows.size(); ++i) {
    const Eigen::Vector3d p(occ.Number(i, "x_m"), occ.Number(i, "y_m"), occ.Number(i, "z_m"));
    const Eigen::Vector3d f = (p - o) / a - Eigen::Vector3d::Constant(0.5);
    const CellIndex c{static_cast<int32_t>(std::lround(f.x())),
                      static_cast<int32_t>(std::lround(f.y())),
                      static_cast<int32_t>(std::lround(f.z()))};
    ASSERT_NEAR(f.x(), c.x, 1e-3);  // a cell centre
    ASSERT_NEAR(f.y(), c.y, 1e-3);
    ASSERT_NEAR(f.z(), c.z, 1e-3);
    EXPECT_GT(occ.Number(i, "p"), 0.5);
    agree += loaded.map->ProbabilityAt(c) > 0.5;
  }
  size_t in_file = 0;
  for (int z = 0; z < g.dims().z; ++z) {
    for (int y = 0; y < g.dims().y; ++y) {
      for (int x = 0; x < g.dims().x; ++x) in_file += loaded.map->ProbabilityAt({x, y, z}) > 0.5;
    }
  }
  EXPECT_GE(static_cast<double>(agree), 0.97 * static_cast<double>(occ.rows.size()));
  EXPECT_NEAR(static_cast<double>(in_file), static_cast<double>(occ.rows.size()),
              0.03 * static_cast<double>(in_file));
}

// Candidates and 2D maps are the logged messages: every candidate of every plan, and each kept
// 2D map equals a MAP2D message of its name, the newest received by the requested time.
TEST(ReportExport, CandidatesAndMap2dAreTheLoggedMessages) {
  std::string dir;
  ExportFixture(&dir);
  const auto plans = ReadChannel<exploration_status_t>(kLog, "EXPLORATION_STATUS");
  ASSERT_GE(plans.size(), 2u);
  size_t total = 0;
  for (const auto& p : plans) total += p.candidates.size();
  const Csv cand = ReadCsv(dir + "/candidates.csv");
  ASSERT_EQ(cand.rows.size(), total);
  size_t row = 0;
  for (size_t k = 0; k < plans.size(); ++k) {
    for (const candidate_t& c : plans[k].candidates) {
      EXPECT_EQ(cand.Number(row, "plan"), static_cast<double>(k));
      EXPECT_NEAR(cand.Number(row, "x_m"), c.position_m[0], 1e-4);
      EXPECT_NEAR(cand.Number(row, "yaw_rad"), c.yaw_rad, 1e-4);
      EXPECT_NEAR(cand.Number(row, "gain_nats"), c.gain_nats, 1e-5 * std::max(1.0, c.gain_nats));
      ++row;
    }
  }

  const auto collision = ReadChannel<grid_map_t>(kLog, "MAP2D_COLLISION");
  ASSERT_FALSE(collision.empty());
  const Csv index = ReadCsv(dir + "/map2d_index.csv");
  int checked = 0;
  for (size_t r = 0; r < index.rows.size(); ++r) {
    if (index.rows[r][index.Column("name")] != "collision") continue;
    const std::string file = dir + "/" + index.rows[r][index.Column("file")];
    const Csv values = ReadCsv(file);  // header = first row of values
    const int width = static_cast<int>(index.Number(r, "width"));
    const int height = static_cast<int>(index.Number(r, "height"));
    ASSERT_EQ(static_cast<int>(values.rows.size()) + 1, height);
    bool found = false;
    for (const grid_map_t& m : collision) {
      if (m.width != width || m.height != height) continue;
      bool same = true;
      for (int y = 0; y < height && same; ++y) {
        const auto& fields = y == 0 ? values.header : values.rows[static_cast<size_t>(y - 1)];
        for (int x = 0; x < width && same; ++x) {
          same = std::abs(std::stod(fields[static_cast<size_t>(x)]) -
                          m.values[static_cast<size_t>(y * width + x)]) < 1e-5;
        }
      }
      found = found || same;
    }
    EXPECT_TRUE(found) << file << " is no logged MAP2D_COLLISION";
    EXPECT_LE(index.Number(r, "time_s"), index.Number(r, "request_time_s") + 1e-6);
    ++checked;
  }
  EXPECT_EQ(checked, 2);
}

// A one-vehicle run is one vehicle without a prefix (docs/design.md §7.10): its path in
// trajectory.csv, its length along those poses, its plans those of EXPLORATION_STATUS.
TEST(ReportExport, OneVehicleRunIsOneVehicleWithoutPrefix) {
  std::string dir;
  const Csv meta = ExportFixture(&dir);
  EXPECT_EQ(Meta(meta, "vehicles"), 1.0);
  const Csv v = ReadCsv(dir + "/vehicles.csv");
  ASSERT_EQ(v.rows.size(), 1u);
  EXPECT_EQ(v.rows[0][v.Column("prefix")], "");
  EXPECT_EQ(v.rows[0][v.Column("trajectory_file")], "trajectory.csv");
  const auto plans = ReadChannel<exploration_status_t>(kLog, "EXPLORATION_STATUS");
  EXPECT_EQ(v.Number(0, "plans"), static_cast<double>(plans.size()));
  const Csv t = ReadCsv(dir + "/trajectory.csv");
  ASSERT_GT(t.rows.size(), 10u);
  double length = 0.0;
  for (size_t i = 1; i < t.rows.size(); ++i) {
    const Eigen::Vector3d a(t.Number(i - 1, "x_m"), t.Number(i - 1, "y_m"), t.Number(i - 1, "z_m"));
    const Eigen::Vector3d b(t.Number(i, "x_m"), t.Number(i, "y_m"), t.Number(i, "z_m"));
    length += (b - a).norm();
  }
  // trajectory.csv rounds to 0.1 mm.
  EXPECT_NEAR(v.Number(0, "path_length_m"), length, 1e-4 * static_cast<double>(t.rows.size()));
  EXPECT_GT(length, 2.0);
}

/// The fields of one CSV line with RFC 4180 quoting ("a, b" and doubled quotes).
std::vector<std::string> SplitQuotedCsv(const std::string& line) {
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

/// The YAML node at a key path of config.csv ("sensors[1].sigma_m") in a file; undefined if absent.
YAML::Node NodeAt(const std::string& file, const std::string& key_path) {
  std::vector<YAML::Node> chain{YAML::LoadFile(file)};
  std::stringstream parts(key_path);
  for (std::string part; std::getline(parts, part, '.');) {
    const size_t bracket = part.find('[');
    const YAML::Node here = chain.back();
    YAML::Node next = here[part.substr(0, bracket)];
    if (bracket != std::string::npos) next = next[std::stoi(part.substr(bracket + 1))];
    if (!next.IsDefined()) return next;
    chain.push_back(next);
  }
  return chain.back();
}

// config.csv is the newest params_t of every node in the log, and every value marked "file" is
// the value at that key in that file (read back here with yaml-cpp), "default" keys are absent.
TEST(ReportExport, ConfigurationIsWhatTheNodesRanWith) {
  std::string dir;
  const Csv meta = ExportFixture(&dir);
  EXPECT_EQ(Meta(meta, "configurations"),
            4.0);  // the mission's simulator, controller, mapper, explorer
  const Csv processes = ReadCsv(dir + "/config_processes.csv");
  ASSERT_EQ(processes.rows.size(), 4u);
  std::ifstream in(dir + "/config.csv");
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line, "channel,process,epoch,key,value,source,file");
  std::map<std::string, std::vector<std::vector<std::string>>> rows_by_channel;
  int from_file = 0, defaults = 0;
  while (std::getline(in, line)) {
    const std::vector<std::string> f = SplitQuotedCsv(line);
    ASSERT_EQ(f.size(), 7u) << line;
    rows_by_channel[f[0]].push_back(f);
    const std::string& key = f[3];
    const std::string& value = f[4];
    const std::string& source = f[5];
    const std::string& file = f[6];
    if (file == "(defaults)") {  // the mission's controller without a file
      EXPECT_EQ(source, "default") << key;
      ++defaults;
      continue;
    }
    const YAML::Node in_file = NodeAt(file, key);
    if (source == "default") {
      EXPECT_FALSE(in_file.IsDefined() && !in_file.IsNull()) << file << ": " << key;
      ++defaults;
      continue;
    }
    if (source != "file") continue;  // the mission's overrides: world_file, seed
    ++from_file;
    ASSERT_TRUE(in_file.IsDefined()) << file << ": " << key;
    if (in_file.IsScalar()) {
      const YAML::Node as_read = YAML::Load(value);
      double a = 0.0, b = 0.0;
      if (YAML::convert<double>::decode(in_file, a) && YAML::convert<double>::decode(as_read, b)) {
        EXPECT_EQ(a, b) << file << ": " << key;
      } else if (in_file.Scalar() != "yes" && in_file.Scalar() != "no") {
        EXPECT_EQ(in_file.Scalar(), value) << file << ": " << key;
      }
    } else {
      EXPECT_TRUE(in_file.IsSequence()) << file << ": " << key;
      EXPECT_EQ(YAML::Load(value).size(), in_file.size()) << file << ": " << key;
    }
  }
  // The fixture's four files set about 320 values; about 20 are left to the code (the lidar's
  // model values, the sensor models' switches, the ceiling).
  EXPECT_GT(from_file, 200);
  EXPECT_GE(defaults, 10);
  // Each channel's rows are its logged message's params, in order.
  for (const char* channel :
       {"PARAMS_SIM", "PARAMS_CONTROLLER", "PARAMS_MAPPER", "PARAMS_EXPLORER"}) {
    const auto logged = ReadChannel<params_t>(kLog, channel);
    ASSERT_EQ(logged.size(), 1u) << channel;
    const auto& rows = rows_by_channel[channel];
    ASSERT_EQ(rows.size(), logged[0].params.size()) << channel;
    for (size_t i = 0; i < rows.size(); ++i) {
      EXPECT_EQ(rows[i][3], logged[0].params[i].key);
      EXPECT_EQ(rows[i][4], logged[0].params[i].value);
    }
  }
  // The simulator's world and vehicle came through its configuration, with their own file names.
  bool world_listed = false, vehicle_listed = false;
  for (const auto& r : rows_by_channel["PARAMS_SIM"]) {
    world_listed = world_listed || r[6].find("config/worlds/lasr.yaml") != std::string::npos;
    vehicle_listed = vehicle_listed || r[6].find("config/vehicle/") != std::string::npos;
  }
  EXPECT_TRUE(world_listed);
  EXPECT_TRUE(vehicle_listed);
}

// An override on the mission's command line is in the log as an override, with the value used.
TEST(ReportExport, ConfigurationShowsOverrides) {
  const ScratchDir scratch("overrides");
  ReportExportConfig c;
  c.log_path = kFixtureDir + "/frontier.lcmlog";
  c.out_dir = scratch.path() + "/out";
  const ReportExportSummary s = ExportReportData(c);
  EXPECT_EQ(s.configurations, 4u);
  std::ifstream in(c.out_dir + "/config.csv");
  bool found = false;
  for (std::string line; std::getline(in, line);) {
    const std::vector<std::string> f = SplitQuotedCsv(line);
    if (f[0] == "PARAMS_EXPLORER" && f[3] == "mode") {
      EXPECT_EQ(f[4], "frontier");
      EXPECT_EQ(f[5], "override");
      found = true;
    }
  }
  EXPECT_TRUE(found);
  const Csv processes = ReadCsv(c.out_dir + "/config_processes.csv");
  ASSERT_EQ(processes.rows.size(), 4u);
  EXPECT_NE(
      processes.rows[0][processes.Column("command_line")].find("--explorer-set mode=frontier"),
      std::string::npos);
}

// A log cut inside an event: the events before the cut are used and a warning says so.
TEST(ReportExport, TruncatedLogUsesTheEventsBeforeTheCut) {
  const ScratchDir scratch("truncated");
  const std::string& dir = scratch.path();
  const std::string cut = dir + "/cut.lcmlog";
  const auto size = std::filesystem::file_size(kLog);
  std::filesystem::copy_file(kLog, cut);
  std::filesystem::resize_file(cut, size / 2 + 7);  // almost surely inside an event
  ReportExportConfig c;
  c.log_path = cut;
  c.out_dir = dir + "/out";
  const ReportExportSummary s = ExportReportData(c);
  EXPECT_TRUE(s.truncated);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(s.warnings[0].find("ends inside an event"), std::string::npos) << s.warnings[0];
  EXPECT_GT(s.samples, 5u);
  EXPECT_LT(s.duration_s, 35.0);
  EXPECT_EQ(s.truth_cells, 0u);  // no world given
}

// Without MAP3D there is no map to draw: a clear error naming the channels the log has.
TEST(ReportExport, LogWithoutMapSnapshotsIsAnError) {
  const ScratchDir scratch("nomap");
  const std::string& dir = scratch.path();
  const std::string path = dir + "/nomap.lcmlog";
  {
    lcm::LogFile in(kLog, "r");
    lcm::LogFile out(path, "w");
    ASSERT_TRUE(in.good() && out.good());
    while (const lcm::LogEvent* e = in.readNextEvent()) {
      if (e->channel == "MAP3D") continue;
      lcm::LogEvent copy = *e;
      ASSERT_EQ(out.writeEvent(&copy), 0);
    }
  }
  ReportExportConfig c;
  c.log_path = path;
  c.out_dir = dir + "/out";
  try {
    (void)ExportReportData(c);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("has no MAP3D message"), std::string::npos) << what;
    EXPECT_NE(what.find("MAP_STATUS ("), std::string::npos) << what;
  }
}

// A file that is no LCM log, a missing file, and malformed messages on a map channel.
TEST(ReportExport, BadFilesAndMalformedMessages) {
  const ScratchDir scratch("bad");
  const std::string& dir = scratch.path();
  ReportExportConfig c;
  c.out_dir = dir + "/out";
  c.log_path = dir + "/missing.lcmlog";
  EXPECT_THROW((void)ExportReportData(c), std::runtime_error);
  c.log_path = dir + "/garbage.lcmlog";
  {
    std::ofstream f(c.log_path, std::ios::binary);
    for (int i = 0; i < 4096; ++i) f.put(static_cast<char>((i * 37) & 0xff));
  }
  try {
    (void)ExportReportData(c);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("has no MAP3D message"), std::string::npos) << e.what();
  }
  // Every MAP3D_DELTA replaced by bytes of the right channel and wrong content.
  c.log_path = dir + "/malformed.lcmlog";
  {
    lcm::LogFile in(kLog, "r");
    lcm::LogFile out(c.log_path, "w");
    std::vector<uint8_t> junk(64, 0xab);
    while (const lcm::LogEvent* e = in.readNextEvent()) {
      lcm::LogEvent copy = *e;
      if (e->channel == "MAP3D_DELTA") {
        copy.data = junk.data();
        copy.datalen = static_cast<int32_t>(junk.size());
      }
      ASSERT_EQ(out.writeEvent(&copy), 0);
    }
  }
  const ReportExportSummary s = ExportReportData(c);
  EXPECT_GT(s.malformed, 10);
  EXPECT_EQ(s.deltas_applied, 0);
  bool warned = false;
  for (const auto& w : s.warnings) warned = warned || w.find("MAP3D_DELTA: malformed") == 0;
  EXPECT_TRUE(warned);
}

// Bad configuration names the field and the accepted range.
TEST(ReportExport, ValidateNamesTheField) {
  ReportExportConfig c;
  c.log_path = kLog;
  c.out_dir = "/tmp/x";
  c.occupied_threshold = 1.5;
  try {
    c.Validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("occupied_threshold = 1.5, accepted (0, 1)"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace kestrel

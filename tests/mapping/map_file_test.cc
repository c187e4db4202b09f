#include "mapping/map_file.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>

#include <octomap/OcTree.h>

#include "mapping/scan_integrator.h"

namespace kestrel {
namespace {

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "kestrel_map_file_test_" + std::to_string(::getpid()) + "_" + name;
}

template <class Map>
void FillRandom(Map* map, uint32_t seed, int rays = 3000) {
  const SensorModel xtion(SensorModelConfig::Xtion());
  ScanIntegrator integrator(map);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int i = 0; i < rays; ++i) {
    const Eigen::Vector3d u = Eigen::Vector3d(n(rng), n(rng), 0.2 * n(rng)).normalized();
    integrator.IntegrateRay(Eigen::Vector3d(0.1, 0.2, 0.7), u,
                            std::uniform_real_distribution<double>(0.6, 4.5)(rng), xtion);
  }
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void WriteAll(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

template <class F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const MapFileError& e) {
    return e.what();
  }
  return "";
}

// Save then load gives a bit-identical map (hash), the same entropy, the run id and the stream
// positions (every publisher epoch, in order), for the exact dense, the log-odds dense and the
// exact growing map.
TEST(MapFile, RoundTripIsBitIdentical) {
  const StreamSequences seqs{
      {"DEPTH_XTION", {{0x7123456789abcdef, 1234}, {42, 7}}},  // a restart: two epochs, in order
      {"SCAN_HOKUYO", {{5, -1}}},
      {"POSE_VICON", {{9, 99}}}};
  auto dense = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  FillRandom(dense.get(), 1);
  const std::string path = TempPath("dense.kmap");
  SaveMap(path, *dense, seqs, "20240611T093012Z-5f3a9c01");
  const LoadedMap<DenseOccupancyMap> loaded = LoadDenseMap(path);
  EXPECT_EQ(loaded.map->Hash(), dense->Hash());
  EXPECT_EQ(loaded.sequences, seqs);
  EXPECT_EQ(loaded.run_id, "20240611T093012Z-5f3a9c01");
  const MapFileInfo info = ReadMapFileInfo(path);
  EXPECT_EQ(info.version, kMapFileVersion);
  EXPECT_TRUE(info.dense);
  EXPECT_EQ(info.run_id, "20240611T093012Z-5f3a9c01");
  EXPECT_EQ(info.sequences, seqs);
  EXPECT_NEAR(loaded.map->entropy_nats(), dense->entropy_nats(), 1e-10 * dense->entropy_nats());
  EXPECT_STREQ(loaded.map->updater().name(), "exact");

  auto log_odds = MakeLogOddsDenseMap(MapLimits{}, LogOddsConfig{}, 4.0);
  FillRandom(log_odds.get(), 2);
  SaveMap(path, *log_odds, {});
  const LoadedMap<DenseOccupancyMap> loaded_lo = LoadDenseMap(path);
  EXPECT_EQ(loaded_lo.map->Hash(), log_odds->Hash());
  EXPECT_EQ(loaded_lo.run_id, "");
  EXPECT_TRUE(loaded_lo.sequences.empty());
  EXPECT_STREQ(loaded_lo.map->updater().name(), "log_odds");

  auto growing = MakeExactGrowingMap(MapLimits{}, OccupancyLimits{}, 4.0);
  FillRandom(growing.get(), 3);
  const std::string gpath = TempPath("growing.kmap");
  SaveMap(gpath, *growing, seqs);
  const LoadedMap<GrowingOccupancyMap> loaded_g = LoadGrowingMap(gpath);
  EXPECT_EQ(loaded_g.map->Hash(), growing->Hash());
  EXPECT_EQ(loaded_g.map->grid().block_count(), growing->grid().block_count());
  EXPECT_EQ(loaded_g.sequences, seqs);
  EXPECT_EQ(loaded_g.run_id, "");
  EXPECT_FALSE(ReadMapFileInfo(gpath).dense);
  // A loaded map keeps working: the same further rays give the same map.
  FillRandom(growing.get(), 4, 500);
  FillRandom(loaded_g.map.get(), 4, 500);
  EXPECT_EQ(loaded_g.map->Hash(), growing->Hash());
  EXPECT_THROW(LoadGrowingMap(path), MapFileError);  // a dense file is not a growing map
  std::remove(path.c_str());
  std::remove(gpath.c_str());
}

// Every single flipped byte (header, stream names, cells, checksum) is refused with a checksum
// or format error, never loaded.
TEST(MapFile, RefusesCorruptFiles) {
  MapLimits small;
  small.max_m = Eigen::Vector3d(-3.0, -5.0, 0.5);  // a small map keeps the file short
  auto map = MakeExactDenseMap(small, OccupancyLimits{}, 4.0);
  FillRandom(map.get(), 5, 200);
  const std::string path = TempPath("corrupt.kmap");
  SaveMap(path, *map, {{"DEPTH_XTION", {{3, 7}}}}, "run-a");
  const std::string good = ReadAll(path);
  ASSERT_NO_THROW(LoadDenseMap(path));
  for (size_t i = 0; i < good.size(); i += (i < 200 ? 1 : 97)) {
    std::string bad = good;
    bad[i] = static_cast<char>(bad[i] ^ 0x10);
    WriteAll(path, bad);
    const std::string error = ErrorOf([&] { LoadDenseMap(path); });
    ASSERT_FALSE(error.empty()) << "flipped byte " << i << " was accepted";
    EXPECT_NE(error.find(path), std::string::npos) << error;
  }
  std::string bad = good;
  bad[good.size() / 2] ^= 1;
  WriteAll(path, bad);
  EXPECT_NE(ErrorOf([&] { LoadDenseMap(path); }).find("checksum mismatch"), std::string::npos);
  std::remove(path.c_str());
}

// Every truncation (including empty) is refused with a clear error.
TEST(MapFile, RefusesTruncatedFiles) {
  MapLimits small;
  small.max_m = Eigen::Vector3d(-3.0, -5.0, 0.5);
  auto map = MakeExactGrowingMap(small, OccupancyLimits{}, 4.0);
  FillRandom(map.get(), 6, 100);
  const std::string path = TempPath("truncated.kmap");
  SaveMap(path, *map, {{"SCAN_HOKUYO", {{4, 3}}}}, "run-b");
  const std::string good = ReadAll(path);
  for (size_t len : {size_t{0}, size_t{5}, size_t{40}, size_t{130}, good.size() / 2,
                     good.size() - 5, good.size() - 1}) {
    WriteAll(path, good.substr(0, len));
    const std::string error = ErrorOf([&] { LoadGrowingMap(path); });
    ASSERT_FALSE(error.empty()) << "truncated to " << len << " was accepted";
    EXPECT_TRUE(error.find("truncated") != std::string::npos ||
                error.find("checksum mismatch") != std::string::npos)
        << error;
  }
  EXPECT_NE(ErrorOf([&] { LoadGrowingMap(TempPath("missing.kmap")); }).find("cannot open"),
            std::string::npos);
  std::remove(path.c_str());
}

// A version 1 file (before publisher epochs and run ids) as the earlier build wrote it: the
// version 2 bytes of `v2` (one epoch per stream) without the run id and the epoch counts and
// epochs, with version 1 and the checksum recomputed.
std::string AsVersion1(const std::string& v2) {
  auto u32 = [&](size_t at) {
    uint32_t v;
    std::memcpy(&v, v2.data() + at, 4);
    return v;
  };
  const size_t header = 8 + 4 + 4 + 4 + 13 * 8;  // through the updater parameters
  std::string v1 = v2.substr(0, header);
  const uint32_t one = 1;
  std::memcpy(v1.data() + 8, &one, 4);
  size_t at = header;
  at += 4 + u32(at);  // the run id
  const uint32_t streams = u32(at);
  v1.append(v2, at, 4);
  at += 4;
  for (uint32_t i = 0; i < streams; ++i) {
    const uint32_t name = u32(at);
    v1.append(v2, at, 4 + name);
    at += 4 + name;
    EXPECT_EQ(u32(at), 1u) << "one epoch per stream";
    at += 4 + 8;           // the epoch count and the epoch
    v1.append(v2, at, 8);  // the sequence
    at += 8;
  }
  v1.append(v2, at, v2.size() - 4 - at);  // the cells, without the old checksum
  const auto crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(v1.data()), static_cast<uInt>(v1.size())));
  v1.append(reinterpret_cast<const char*>(&crc), 4);
  return v1;
}

// Files of version 1 still load (map_score, the report and gain_probe read older maps): the same
// cells, no run id, and each stream's sequence under kUnknownEpoch, which no publisher stamps.
// A version this build does not know is refused by number.
TEST(MapFile, ReadsVersion1AndRefusesUnknownVersions) {
  MapLimits small;
  small.max_m = Eigen::Vector3d(-3.0, -5.0, 0.5);
  auto map = MakeExactDenseMap(small, OccupancyLimits{}, 4.0);
  FillRandom(map.get(), 8, 300);
  const std::string path = TempPath("v1.kmap");
  SaveMap(path, *map,
          {{"DEPTH_XTION", {{kUnknownEpoch, 17}}}, {"SCAN_HOKUYO", {{kUnknownEpoch, 4}}}}, "");
  const std::string v2 = ReadAll(path);
  WriteAll(path, AsVersion1(v2));
  const LoadedMap<DenseOccupancyMap> loaded = LoadDenseMap(path);
  EXPECT_EQ(loaded.map->Hash(), map->Hash());
  EXPECT_EQ(loaded.run_id, "");
  const StreamSequences expected{{"DEPTH_XTION", {{kUnknownEpoch, 17}}},
                                 {"SCAN_HOKUYO", {{kUnknownEpoch, 4}}}};
  EXPECT_EQ(loaded.sequences, expected);
  EXPECT_EQ(ReadMapFileInfo(path).version, 1u);
  EXPECT_LT(ReadAll(path).size(), v2.size());  // it really is the shorter, older layout

  std::string v3 = v2;
  const uint32_t three = 3;
  std::memcpy(v3.data() + 8, &three, 4);
  v3.resize(v3.size() - 4);
  const auto crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(v3.data()), static_cast<uInt>(v3.size())));
  v3.append(reinterpret_cast<const char*>(&crc), 4);
  WriteAll(path, v3);
  EXPECT_NE(
      ErrorOf([&] { LoadDenseMap(path); }).find("version 3, this build reads versions 1 to 2"),
      std::string::npos)
      << ErrorOf([&] { LoadDenseMap(path); });
  std::remove(path.c_str());
}

// The bytes with their checksum recomputed (what a file corrupted consistently looks like).
std::string WithCrc(std::string bytes) {
  bytes.resize(bytes.size() - 4);
  const auto crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size())));
  bytes.append(reinterpret_cast<const char*>(&crc), 4);
  return bytes;
}

// A dense file whose limits claim far more cells than it holds (8e5 cells a side, accepted by
// MapLimits, 5e17 in all) is refused by its cell count before the grid is allocated: a
// MapFileError, not a bad_alloc or an attempt to allocate 2 EB. The pure core and the file
// loader agree.
TEST(MapFile, LimitsBeyondTheStoredCellsAreRefusedBeforeAllocating) {
  MapLimits small;
  small.max_m = Eigen::Vector3d(-3.0, -5.0, 0.5);
  auto map = MakeExactDenseMap(small, OccupancyLimits{}, 4.0);
  std::string bytes = EncodeMap(*map, {}, "run-a");
  const size_t max_at = 8 + 4 + 4 + 4 + 8 + 3 * 8;  // magic ... resolution, origin
  for (int a = 0; a < 3; ++a) {
    const double max_m = small.min_m[a] + 8e5 * small.resolution_m - 0.5 * small.resolution_m;
    std::memcpy(bytes.data() + max_at + 8 * a, &max_m, 8);
  }
  bytes = WithCrc(bytes);
  const std::string error = ErrorOf([&] { (void)DecodeDenseMap(bytes, "huge.kmap"); });
  EXPECT_NE(error.find("the limits give 512000000000000000"), std::string::npos) << error;
  const std::string path = TempPath("huge.kmap");
  WriteAll(path, bytes);
  EXPECT_EQ(ErrorOf([&] { (void)LoadDenseMap(path); }),
            "map file " + path + error.substr(error.find(':')));
  std::remove(path.c_str());
}

// A maximum range the map itself refuses (a growing map's cast window holds 507 cells; a
// log-odds file's range is checked by nothing before the map) is a MapFileError, as the loaders
// promise, not the map constructor's std::invalid_argument.
TEST(MapFile, RangesTheMapRefusesAreMapFileErrors) {
  MapLimits small;
  small.max_m = Eigen::Vector3d(-3.0, -5.0, 0.5);
  const size_t range_at = 8 + 4 + 4 + 4 + 8 + 3 * 8 + 3 * 8;  // ... origin, limits
  auto set_range = [&](std::string bytes, double range_m) {
    std::memcpy(bytes.data() + range_at, &range_m, 8);
    return WithCrc(bytes);
  };
  auto growing = MakeExactGrowingMap(small, OccupancyLimits{}, 4.0);
  const std::string g = set_range(EncodeMap(*growing, {}), 100.0);  // 1334 cells
  EXPECT_NE(ErrorOf([&] { (void)DecodeGrowingMap(g, "g.kmap"); }).find("invalid map"),
            std::string::npos);
  auto log_odds = MakeLogOddsDenseMap(small, LogOddsConfig{}, 4.0);
  const std::string d = set_range(EncodeMap(*log_odds, {}), -1.0);
  EXPECT_NE(ErrorOf([&] { (void)DecodeDenseMap(d, "d.kmap"); }).find("invalid map"),
            std::string::npos);
}

// A range of a million cells (75 km at 7.5 cm) would size the map's ray scratch at hundreds of
// megabytes for a file of a few kilobytes; the loaders refuse more than 65536 cells (and a
// non-finite range) before building anything.
TEST(MapFile, RangesOfMoreThan65536CellsAreRefused) {
  MapLimits small;
  small.max_m = Eigen::Vector3d(-3.0, -5.0, 0.5);
  const size_t range_at = 8 + 4 + 4 + 4 + 8 + 3 * 8 + 3 * 8;
  auto dense = MakeExactDenseMap(small, OccupancyLimits{}, 4.0);
  for (const double range_m : {1e6 * small.resolution_m, std::nan(""), 1e300}) {
    std::string bytes = EncodeMap(*dense, {});
    std::memcpy(bytes.data() + range_at, &range_m, 8);
    bytes = WithCrc(bytes);
    const std::string error = ErrorOf([&] { (void)DecodeDenseMap(bytes, "r.kmap"); });
    EXPECT_NE(error.find("accepted at most 65536 cells"), std::string::npos) << error;
  }
}

// The bytes SaveMap writes are EncodeMap's, and the pure loaders read them as the file loaders.
TEST(MapFile, EncodeAndDecodeAreTheFileFormat) {
  MapLimits small;
  small.max_m = Eigen::Vector3d(-3.0, -5.0, 0.5);
  auto map = MakeExactGrowingMap(small, OccupancyLimits{}, 4.0);
  FillRandom(map.get(), 9, 200);
  const StreamSequences seqs{{"SCAN_HOKUYO", {{4, 3}}}};
  const std::string path = TempPath("encode.kmap");
  SaveMap(path, *map, seqs, "run-c");
  const std::string bytes = EncodeMap(*map, seqs, "run-c");
  EXPECT_EQ(ReadAll(path), bytes);
  const LoadedMap<GrowingOccupancyMap> loaded = DecodeGrowingMap(bytes, "x.kmap");
  EXPECT_EQ(loaded.map->Hash(), map->Hash());
  EXPECT_EQ(loaded.run_id, "run-c");
  EXPECT_EQ(DecodeMapFileInfo(bytes, "x.kmap").sequences, seqs);
  std::remove(path.c_str());
}

// OctoMap export through the real library: reading the .bt and .ot back with OctoMap, every
// Kestrel cell with P > 0.5 is an occupied voxel at its centre and every observed cell with
// P < 0.5 a free one.
TEST(MapFile, OctoMapExportReadsBackInOctoMap) {
  auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  FillRandom(map.get(), 7);
  const std::string bt = TempPath("map.bt");
  const std::string ot = TempPath("map.ot");
  ExportOctoMap(bt, *map);
  ExportOctoMap(ot, *map);
  octomap::OcTree from_bt(bt);
  std::unique_ptr<octomap::AbstractOcTree> abstract(octomap::AbstractOcTree::read(ot));
  ASSERT_NE(abstract, nullptr);
  auto* from_ot = dynamic_cast<octomap::OcTree*>(abstract.get());
  ASSERT_NE(from_ot, nullptr);
  const GridGeometry& g = map->grid().geometry();
  int occupied = 0, free_cells = 0;
  const CellIndex d = map->grid().dims();
  for (int z = 0; z < d.z; ++z) {
    for (int y = 0; y < d.y; ++y) {
      for (int x = 0; x < d.x; ++x) {
        const CellIndex c{x, y, z};
        const float v = map->grid().Get(c);
        if (v == 0.1f) continue;
        const Eigen::Vector3d p = g.CenterOf(c);
        const octomap::point3d q(static_cast<float>(p.x()), static_cast<float>(p.y()),
                                 static_cast<float>(p.z()));
        const octomap::OcTreeNode* nb = from_bt.search(q);
        const octomap::OcTreeNode* no = from_ot->search(q);
        ASSERT_NE(nb, nullptr);
        ASSERT_NE(no, nullptr);
        if (v > 0.5f) {
          ++occupied;
          EXPECT_TRUE(from_bt.isNodeOccupied(nb));
          EXPECT_NEAR(no->getOccupancy(), v, 1e-5);
        } else if (v < 0.5f) {
          ++free_cells;
          EXPECT_FALSE(from_bt.isNodeOccupied(nb));
          EXPECT_NEAR(no->getOccupancy(), v, 1e-5);
        }
      }
    }
  }
  EXPECT_GT(occupied, 10);
  EXPECT_GT(free_cells, 1000);
  EXPECT_THROW(ExportOctoMap(TempPath("map.txt"), *map), MapFileError);
  std::remove(bt.c_str());
  std::remove(ot.c_str());
}

// PLY: a header with the vertex count, then the centres of exactly the cells with P > 0.5.
TEST(MapFile, PlyHoldsOccupiedCellCentres) {
  auto map = MakeExactDenseMap(MapLimits{}, OccupancyLimits{}, 4.0);
  FillRandom(map.get(), 8);
  const std::string path = TempPath("occupied.ply");
  const size_t n = ExportOccupiedPly(path, *map);
  size_t expected = 0;
  for (float v : map->grid().values()) expected += v > 0.5f;
  EXPECT_EQ(n, expected);
  EXPECT_GT(n, 10u);
  std::ifstream in(path);
  std::string line;
  size_t declared = 0;
  while (std::getline(in, line) && line != "end_header") {
    if (line.rfind("element vertex ", 0) == 0) declared = std::stoul(line.substr(15));
  }
  EXPECT_EQ(declared, n);
  size_t rows = 0;
  double x, y, z, p;
  while (in >> x >> y >> z >> p) {
    const auto c = map->grid().geometry().CellOf(Eigen::Vector3d(x, y, z));
    ASSERT_TRUE(c.has_value());
    EXPECT_NEAR(map->ProbabilityAt(*c), p, 1e-6);
    EXPECT_GT(p, 0.5);
    ++rows;
  }
  EXPECT_EQ(rows, n);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace kestrel

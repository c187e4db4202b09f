#include "mapping/map_file.h"

#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <type_traits>
#include <vector>

#include <octomap/OcTree.h>

#include "common/check.h"

namespace kestrel {
namespace {

constexpr char kMagic[8] = {'K', 'S', 'T', 'R', 'L', 'M', 'A', 'P'};
constexpr uint32_t kByteOrderMark = 0x01020304u;
constexpr uint8_t kDense = 0;
constexpr uint8_t kGrowing = 1;
constexpr uint8_t kExact = 0;
constexpr uint8_t kLogOdds = 1;

class Writer {
 public:
  template <class T>
  void Put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const char*>(&v);
    bytes_.append(p, sizeof(T));
  }
  void PutBytes(const void* data, size_t size) {
    bytes_.append(static_cast<const char*>(data), size);
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

class Reader {
 public:
  Reader(const std::string& path, const char* data, size_t size)
      : path_(path), data_(data), size_(size) {}
  template <class T>
  T Get(const char* what) {
    T v;
    GetBytes(&v, sizeof(T), what);
    return v;
  }
  void GetBytes(void* out, size_t size, const char* what) {
    if (size > size_ - pos_) {
      throw MapFileError("map file " + path_ + ": truncated while reading " + what);
    }
    std::memcpy(out, data_ + pos_, size);
    pos_ += size;
  }
  [[nodiscard]] size_t remaining() const { return size_ - pos_; }

 private:
  std::string path_;
  const char* data_;
  size_t size_;
  size_t pos_{0};
};

struct Header {
  uint32_t version{0};
  uint8_t grid_kind{0};
  uint8_t updater_kind{0};
  double resolution_m{0.0};
  Eigen::Vector3d origin_m{Eigen::Vector3d::Zero()};
  Eigen::Vector3d max_m{Eigen::Vector3d::Zero()};
  double max_range_m{0.0};
  double params[5]{};
  std::string run_id;
  StreamSequences sequences;
};

// Names, run ids and counts are written with u32 lengths; anything longer cannot be stored.
constexpr size_t kMaxNameBytes = 4096;

void PutName(Writer* w, const std::string& name, const char* what) {
  if (name.size() > kMaxNameBytes) {
    throw MapFileError(std::string("SaveMap: ") + what + " of " + std::to_string(name.size()) +
                       " bytes (at most " + std::to_string(kMaxNameBytes) + ")");
  }
  w->Put(static_cast<uint32_t>(name.size()));
  w->PutBytes(name.data(), name.size());
}

template <class Grid>
void WriteHeader(Writer* w, const OccupancyMap<Grid>& map, uint8_t grid_kind,
                 const Eigen::Vector3d& max_m, const StreamSequences& sequences,
                 const std::string& run_id) {
  w->PutBytes(kMagic, sizeof(kMagic));
  w->Put(kMapFileVersion);
  w->Put(kByteOrderMark);
  w->Put(grid_kind);
  double params[5] = {0, 0, 0, 0, 0};
  uint8_t updater_kind;
  if (const auto* exact = dynamic_cast<const ExactBayesUpdater*>(&map.updater())) {
    updater_kind = kExact;
    params[0] = exact->limits().p_init;
    params[1] = exact->limits().p_min;
  } else if (const auto* lo = dynamic_cast<const LogOddsUpdater*>(&map.updater())) {
    updater_kind = kLogOdds;
    params[0] = lo->config().p_hit;
    params[1] = lo->config().p_miss;
    params[2] = lo->config().p_clamp_min;
    params[3] = lo->config().p_clamp_max;
    params[4] = lo->config().p_unknown;
  } else {
    throw MapFileError("SaveMap: unknown updater type " + std::string(map.updater().name()));
  }
  w->Put(updater_kind);
  w->Put(uint16_t{0});
  const GridGeometry& g = map.grid().geometry();
  w->Put(g.resolution_m());
  for (int a = 0; a < 3; ++a) w->Put(g.origin_m()[a]);
  for (int a = 0; a < 3; ++a) w->Put(max_m[a]);
  w->Put(map.max_range_m());
  for (double p : params) w->Put(p);
  PutName(w, run_id, "run id");
  w->Put(static_cast<uint32_t>(sequences.size()));
  for (const auto& [name, epochs] : sequences) {
    PutName(w, name, "stream name");
    w->Put(static_cast<uint32_t>(epochs.size()));
    for (const EpochSequence& e : epochs) {
      w->Put(e.epoch);
      w->Put(e.last_seq);
    }
  }
}

void AppendCrc(std::string* bytes) {
  const uint32_t crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(bytes->data()), static_cast<uInt>(bytes->size())));
  bytes->append(reinterpret_cast<const char*>(&crc), sizeof(crc));
}

void WriteFile(const std::string& path, const std::string* bytes) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw MapFileError("map file " + tmp + ": cannot open for writing");
    out.write(bytes->data(), static_cast<std::streamsize>(bytes->size()));
    out.flush();
    if (!out) throw MapFileError("map file " + tmp + ": write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    throw MapFileError("map file " + path + ": cannot rename " + tmp + " over it");
  }
}

std::string ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapFileError("map file " + path + ": cannot open");
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Checks length, magic and CRC of a whole file's bytes; returns the size without the CRC.
size_t VerifiedSize(const std::string& bytes, const std::string& path) {
  const size_t kMinSize = sizeof(kMagic) + 4 + 4 + 4 + size_t{8} * 12 + 4 + 8 + 4;
  if (bytes.size() < kMinSize) {
    throw MapFileError("map file " + path + ": truncated (" + std::to_string(bytes.size()) +
                       " bytes, a map file has at least " + std::to_string(kMinSize) + ")");
  }
  if (std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    throw MapFileError("map file " + path + ": not a Kestrel map file (bad magic)");
  }
  uint32_t stored_crc;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  const uint32_t crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size() - 4)));
  if (crc != stored_crc) {
    throw MapFileError("map file " + path + ": checksum mismatch (file corrupt or truncated)");
  }
  return bytes.size() - 4;
}

Header ReadHeader(const std::string& path, Reader* r) {
  char magic[8];
  r->GetBytes(magic, 8, "magic");
  const auto version = r->Get<uint32_t>("version");
  if (version != 1 && version != kMapFileVersion) {
    throw MapFileError("map file " + path + ": version " + std::to_string(version) +
                       ", this build reads versions 1 to " + std::to_string(kMapFileVersion));
  }
  if (r->Get<uint32_t>("byte-order mark") != kByteOrderMark) {
    throw MapFileError("map file " + path + ": written with another byte order");
  }
  Header h;
  h.version = version;
  h.grid_kind = r->Get<uint8_t>("grid kind");
  h.updater_kind = r->Get<uint8_t>("updater kind");
  r->Get<uint16_t>("reserved");
  h.resolution_m = r->Get<double>("resolution");
  for (int a = 0; a < 3; ++a) h.origin_m[a] = r->Get<double>("origin");
  for (int a = 0; a < 3; ++a) h.max_m[a] = r->Get<double>("limits");
  h.max_range_m = r->Get<double>("max range");
  for (double& p : h.params) p = r->Get<double>("updater parameters");
  auto get_name = [&](const char* what) {
    const auto length = r->Get<uint32_t>(what);
    if (length > r->remaining()) {
      throw MapFileError("map file " + path + ": " + what + " " + std::to_string(length) +
                         " exceeds the file");
    }
    std::string name(length, '\0');
    r->GetBytes(name.data(), length, what);
    return name;
  };
  if (version >= 2) h.run_id = get_name("run id length");
  const auto streams = r->Get<uint32_t>("stream count");
  for (uint32_t i = 0; i < streams; ++i) {
    const std::string name = get_name("stream name length");
    std::vector<EpochSequence>& epochs = h.sequences[name];
    if (version == 1) {  // one sequence, from before publisher epochs
      epochs.push_back(EpochSequence{kUnknownEpoch, r->Get<int64_t>("stream sequence")});
      continue;
    }
    const auto count = r->Get<uint32_t>("epoch count");
    if (count > r->remaining() / (2 * sizeof(int64_t))) {
      throw MapFileError("map file " + path + ": " + std::to_string(count) + " epochs of stream " +
                         name + " exceed the file");
    }
    for (uint32_t k = 0; k < count; ++k) {
      EpochSequence e;
      e.epoch = r->Get<int64_t>("stream epoch");
      e.last_seq = r->Get<int64_t>("stream sequence");
      epochs.push_back(e);
    }
  }
  if (h.updater_kind != kExact && h.updater_kind != kLogOdds) {
    throw MapFileError("map file " + path + ": unknown updater kind " +
                       std::to_string(h.updater_kind));
  }
  return h;
}

// The most cells a ray of the maximum range may cross per axis that a file may claim: the map
// sizes its ray scratch from max_range_m / resolution_m (up to 1e7 cells, about a gigabyte, for
// a file of a few hundred bytes), and no sensor needs more than this (4.9 km at 7.5 cm cells).
constexpr double kMaxRangeCells = 65536;

std::unique_ptr<OccupancyUpdater> MakeUpdater(const std::string& path, const Header& h) {
  if (!(h.max_range_m / h.resolution_m <= kMaxRangeCells)) {
    throw MapFileError("map file " + path + ": max range " + std::to_string(h.max_range_m) +
                       " m at resolution " + std::to_string(h.resolution_m) +
                       " m, accepted at most " + std::to_string(static_cast<int>(kMaxRangeCells)) +
                       " cells");
  }
  try {
    if (h.updater_kind == kExact) {
      OccupancyLimits limits;
      limits.p_init = h.params[0];
      limits.p_min = h.params[1];
      return std::make_unique<ExactBayesUpdater>(
          limits, RayCells::CapacityFor(h.max_range_m, h.resolution_m), h.resolution_m);
    }
    LogOddsConfig c;
    c.p_hit = h.params[0];
    c.p_miss = h.params[1];
    c.p_clamp_min = h.params[2];
    c.p_clamp_max = h.params[3];
    c.p_unknown = h.params[4];
    return std::make_unique<LogOddsUpdater>(c);
  } catch (const std::invalid_argument& e) {
    throw MapFileError("map file " + path + ": invalid parameters: " + e.what());
  }
}

// Calls f(cell, stored value) for every stored cell of either grid.
template <class F>
void ForEachStoredCell(const DenseGrid& grid, F&& f) {
  const CellIndex d = grid.dims();
  size_t i = 0;
  for (int z = 0; z < d.z; ++z)
    for (int y = 0; y < d.y; ++y)
      for (int x = 0; x < d.x; ++x) f(CellIndex{x, y, z}, grid.values()[i++]);
}
template <class F>
void ForEachStoredCell(const GrowingGrid& grid, F&& f) {
  grid.ForEachBlock([&](const CellIndex& origin, const GrowingGrid::Block& block) {
    for (int i = 0; i < GrowingGrid::kBlockCells; ++i) {
      const CellIndex c{origin.x + (i & 7), origin.y + ((i >> 3) & 7), origin.z + (i >> 6)};
      f(c, block.values[i]);
    }
  });
}

template <class Grid>
void ExportOctoMapImpl(const std::string& path, const OccupancyMap<Grid>& map) {
  const bool binary = path.size() > 3 && path.compare(path.size() - 3, 3, ".bt") == 0;
  const bool full = path.size() > 3 && path.compare(path.size() - 3, 3, ".ot") == 0;
  if (!binary && !full) throw MapFileError("ExportOctoMap: " + path + ": use .bt or .ot");
  const GridGeometry& g = map.grid().geometry();
  octomap::OcTree tree(g.resolution_m());
  tree.setClampingThresMin(1e-6);
  tree.setClampingThresMax(1.0 - 1e-6);
  const float untouched = map.updater().initial_value();
  ForEachStoredCell(map.grid(), [&](const CellIndex& c, float v) {
    if (v == untouched) return;
    const double p = map.updater().ProbabilityOf(v);
    const Eigen::Vector3d center = g.CenterOf(c);
    tree.setNodeValue(
        octomap::point3d(static_cast<float>(center.x()), static_cast<float>(center.y()),
                         static_cast<float>(center.z())),
        static_cast<float>(std::log(p / (1.0 - p))));
  });
  const bool ok = binary ? tree.writeBinary(path) : tree.write(path);
  if (!ok) throw MapFileError("ExportOctoMap: cannot write " + path);
}

template <class Grid>
size_t ExportPlyImpl(const std::string& path, const OccupancyMap<Grid>& map) {
  const GridGeometry& g = map.grid().geometry();
  std::ostringstream body;
  body.precision(9);
  size_t count = 0;
  ForEachStoredCell(map.grid(), [&](const CellIndex& c, float v) {
    const double p = map.updater().ProbabilityOf(v);
    if (!(p > 0.5)) return;
    const Eigen::Vector3d center = g.CenterOf(c);
    body << center.x() << ' ' << center.y() << ' ' << center.z() << ' ' << p << '\n';
    ++count;
  });
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw MapFileError("ExportOccupiedPly: cannot open " + path);
  out << "ply\nformat ascii 1.0\ncomment Kestrel occupied cells (P > 0.5), centres in W, m\n"
      << "element vertex " << count
      << "\nproperty float x\nproperty float y\nproperty float z\nproperty float probability\n"
      << "end_header\n"
      << body.str();
  if (!out) throw MapFileError("ExportOccupiedPly: write failed " + path);
  return count;
}

}  // namespace

std::string EncodeMap(const DenseOccupancyMap& map, const StreamSequences& sequences,
                      const std::string& run_id) {
  Writer w;
  const GridGeometry& g = map.grid().geometry();
  Eigen::Vector3d max_m;
  // Half a cell inside the last cell: ceil((max - min)/alpha) gives the same count on loading,
  // immune to rounding.
  for (int a = 0; a < 3; ++a) max_m[a] = g.origin_m()[a] + (g.upper()[a] - 0.5) * g.resolution_m();
  WriteHeader(&w, map, kDense, max_m, sequences, run_id);
  w.Put(static_cast<uint64_t>(map.grid().size()));
  w.PutBytes(map.grid().values().data(), map.grid().size() * sizeof(float));
  AppendCrc(&w.bytes());
  return std::move(w.bytes());
}

std::string EncodeMap(const GrowingOccupancyMap& map, const StreamSequences& sequences,
                      const std::string& run_id) {
  Writer w;
  WriteHeader(&w, map, kGrowing, map.grid().geometry().origin_m(), sequences, run_id);
  w.Put(static_cast<uint64_t>(map.grid().block_count()));
  map.grid().ForEachBlock([&](const CellIndex& origin, const GrowingGrid::Block& block) {
    w.Put(origin.x);
    w.Put(origin.y);
    w.Put(origin.z);
    w.PutBytes(block.values, sizeof(block.values));
  });
  AppendCrc(&w.bytes());
  return std::move(w.bytes());
}

void SaveMap(const std::string& path, const DenseOccupancyMap& map,
             const StreamSequences& sequences, const std::string& run_id) {
  const std::string bytes = EncodeMap(map, sequences, run_id);
  WriteFile(path, &bytes);
}

void SaveMap(const std::string& path, const GrowingOccupancyMap& map,
             const StreamSequences& sequences, const std::string& run_id) {
  const std::string bytes = EncodeMap(map, sequences, run_id);
  WriteFile(path, &bytes);
}

LoadedMap<DenseOccupancyMap> DecodeDenseMap(const std::string& bytes, const std::string& path) {
  Reader r(path, bytes.data(), VerifiedSize(bytes, path));
  const Header h = ReadHeader(path, &r);
  if (h.grid_kind != kDense) throw MapFileError("map file " + path + ": not a dense map");
  MapLimits limits;
  limits.min_m = h.origin_m;
  limits.max_m = h.max_m;
  limits.resolution_m = h.resolution_m;
  // The cell count the limits give, checked against the cells the file holds before the grid
  // (up to 2^60 cells by its own limits) is allocated.
  uint64_t cells_from_limits = 0;
  try {
    const CellIndex dims = GridGeometry::Fixed(limits).upper();
    cells_from_limits = static_cast<uint64_t>(dims.x) * static_cast<uint64_t>(dims.y) *
                        static_cast<uint64_t>(dims.z);
  } catch (const std::invalid_argument& e) {
    throw MapFileError("map file " + path + ": invalid limits: " + e.what());
  }
  const auto count = r.Get<uint64_t>("cell count");
  if (count != cells_from_limits || count > r.remaining() / sizeof(float) ||
      count * sizeof(float) != r.remaining()) {
    throw MapFileError("map file " + path + ": " + std::to_string(count) + " cells with " +
                       std::to_string(r.remaining()) + " bytes left, the limits give " +
                       std::to_string(cells_from_limits));
  }
  std::unique_ptr<OccupancyUpdater> updater = MakeUpdater(path, h);
  auto grid = std::make_unique<DenseGrid>(limits, updater->initial_value());
  r.GetBytes(grid->mutable_values().data(), count * sizeof(float), "cells");
  LoadedMap<DenseOccupancyMap> out;
  try {
    out.map =
        std::make_unique<DenseOccupancyMap>(std::move(*grid), std::move(updater), h.max_range_m);
  } catch (const std::invalid_argument& e) {
    throw MapFileError("map file " + path + ": invalid map: " + e.what());
  }
  out.run_id = h.run_id;
  out.sequences = h.sequences;
  return out;
}

LoadedMap<GrowingOccupancyMap> DecodeGrowingMap(const std::string& bytes, const std::string& path) {
  Reader r(path, bytes.data(), VerifiedSize(bytes, path));
  const Header h = ReadHeader(path, &r);
  if (h.grid_kind != kGrowing) throw MapFileError("map file " + path + ": not a growing map");
  std::unique_ptr<OccupancyUpdater> updater = MakeUpdater(path, h);
  std::unique_ptr<GrowingGrid> grid;
  try {
    grid = std::make_unique<GrowingGrid>(h.origin_m, h.resolution_m, updater->initial_value());
  } catch (const std::invalid_argument& e) {
    throw MapFileError("map file " + path + ": invalid lattice: " + e.what());
  }
  const auto blocks = r.Get<uint64_t>("block count");
  const size_t block_bytes = 3 * sizeof(int32_t) + sizeof(GrowingGrid::Block);
  if (blocks > r.remaining() / block_bytes || blocks * block_bytes != r.remaining()) {
    throw MapFileError("map file " + path + ": " + std::to_string(blocks) + " blocks with " +
                       std::to_string(r.remaining()) + " bytes left");
  }
  for (uint64_t b = 0; b < blocks; ++b) {
    CellIndex origin;
    origin.x = r.Get<int32_t>("block origin");
    origin.y = r.Get<int32_t>("block origin");
    origin.z = r.Get<int32_t>("block origin");
    const int32_t limit = GridGeometry::kUnboundedCells;
    for (int a = 0; a < 3; ++a) {
      if (origin[a] % GrowingGrid::kBlockEdge != 0 || origin[a] <= -limit || origin[a] >= limit) {
        throw MapFileError("map file " + path + ": bad block origin");
      }
    }
    GrowingGrid::Block* block = grid->FindOrCreateBlock(origin);
    r.GetBytes(block->values, sizeof(block->values), "block");
  }
  LoadedMap<GrowingOccupancyMap> out;
  try {
    out.map =
        std::make_unique<GrowingOccupancyMap>(std::move(*grid), std::move(updater), h.max_range_m);
  } catch (const std::invalid_argument& e) {
    throw MapFileError("map file " + path + ": invalid map: " + e.what());
  }
  out.run_id = h.run_id;
  out.sequences = h.sequences;
  return out;
}

MapFileInfo DecodeMapFileInfo(const std::string& bytes, const std::string& path) {
  Reader r(path, bytes.data(), VerifiedSize(bytes, path));
  const Header h = ReadHeader(path, &r);
  if (h.grid_kind != kDense && h.grid_kind != kGrowing) {
    throw MapFileError("map file " + path + ": unknown grid kind " + std::to_string(h.grid_kind));
  }
  MapFileInfo info;
  info.version = h.version;
  info.dense = h.grid_kind == kDense;
  info.run_id = h.run_id;
  info.sequences = h.sequences;
  return info;
}

LoadedMap<DenseOccupancyMap> LoadDenseMap(const std::string& path) {
  return DecodeDenseMap(ReadFileBytes(path), path);
}

LoadedMap<GrowingOccupancyMap> LoadGrowingMap(const std::string& path) {
  return DecodeGrowingMap(ReadFileBytes(path), path);
}

MapFileInfo ReadMapFileInfo(const std::string& path) {
  return DecodeMapFileInfo(ReadFileBytes(path), path);
}

void ExportOctoMap(const std::string& path, const DenseOccupancyMap& map) {
  ExportOctoMapImpl(path, map);
}
void ExportOctoMap(const std::string& path, const GrowingOccupancyMap& map) {
  ExportOctoMapImpl(path, map);
}
size_t ExportOccupiedPly(const std::string& path, const DenseOccupancyMap& map) {
  return ExportPlyImpl(path, map);
}
size_t ExportOccupiedPly(const std::string& path, const GrowingOccupancyMap& map) {
  return ExportPlyImpl(path, map);
}

}  // namespace kestrel

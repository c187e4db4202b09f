// The bridge's voxel stream and frames: a page that applies the snapshot and then every update
// frame holds exactly the occupied cells of mapping/map_replica.h fed the same messages, also when
// it joins late, when map deltas coalesce, across a lost delta and for a growing map.
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "lcmtypes/message_codecs.h"
#include "mapping/map_replica.h"
#include "viewer/bridge/viewer_scene.h"
#include "viewer/bridge/voxel_stream.h"

namespace kestrel {
namespace {

constexpr double kThreshold = 0.5;
using Cell = std::tuple<int, int, int>;
using CellValues = std::map<Cell, int>;  // cell -> q

// The byte a cell with probability p should show as, written out from the protocol's text.
int ExpectedQ(double p) {
  if (!(p > kThreshold)) return 0;
  return std::max(1, static_cast<int>(std::lround(p * 255.0)));
}

// A page: decodes voxel frames by the documented layout (independent of the encoder).
struct Page {
  CellValues cells;
  int64_t map_seq{-1};
  int snapshots{0};
  int deltas{0};

  static int64_t ReadLe(const std::string& b, size_t at, int bytes) {
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(b[at + i]);
    return static_cast<int64_t>(v);
  }
  void Apply(const ViewerFrame& frame) {
    if (!frame.binary || frame.bytes.empty() || frame.bytes[0] != 1) return;
    const std::string& b = frame.bytes;
    ASSERT_GE(b.size(), 48u);
    const bool reset = (b[1] & 1) != 0;
    const auto n = static_cast<size_t>(ReadLe(b, 4, 4));
    ASSERT_EQ(b.size(), 48 + 8 * n);
    map_seq = ReadLe(b, 40, 8);
    if (reset) {
      cells.clear();
      ++snapshots;
    } else {
      ++deltas;
    }
    for (size_t i = 0; i < n; ++i) {
      const size_t o = 48 + 8 * i;
      const auto x = static_cast<int16_t>(ReadLe(b, o, 2));
      const auto y = static_cast<int16_t>(ReadLe(b, o + 2, 2));
      const auto z = static_cast<int16_t>(ReadLe(b, o + 4, 2));
      const int q = static_cast<uint8_t>(b[o + 6]);
      if (q == 0) {
        cells.erase({x, y, z});
      } else {
        cells[{x, y, z}] = q;
      }
    }
  }
  void Apply(const std::vector<ViewerFrame>& frames) {
    for (const ViewerFrame& f : frames) Apply(f);
  }
};

// A small mapper: a dense lattice (dims not multiples of 8) of probabilities, changed at random,
// published as snapshot chunks and deltas exactly as the message comments say.
class FakeMapper {
 public:
  FakeMapper(const Eigen::Vector3i& dims, uint32_t seed)
      : dims_(dims), p_(static_cast<size_t>(dims.prod()), kPInit), published_(p_), rng_(seed) {}

  static constexpr double kPInit = 0.1;
  const Eigen::Vector3d origin_m{0.5, -8.3, -0.15};
  const double resolution_m = 0.075;

  // Changes `count` random cells: some far above or below the threshold, some near it (small
  // changes of q), some back to the prior.
  void Change(int count) {
    std::uniform_int_distribution<int> cell(0, static_cast<int>(p_.size()) - 1);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int i = 0; i < count; ++i) {
      float& p = p_[static_cast<size_t>(cell(rng_))];
      const double kind = u(rng_);
      if (kind < 0.4) {
        p = static_cast<float>(0.5 + 0.5 * u(rng_));
      } else if (kind < 0.6) {
        p = static_cast<float>(kThreshold + 0.02 * (u(rng_) - 0.5));
      } else if (kind < 0.8) {
        p = static_cast<float>(0.3 * u(rng_));
      } else {
        p = static_cast<float>(kPInit);
      }
    }
    ++seq_;
  }

  std::vector<map3d_chunk_t> Snapshot(int blocks_per_chunk, int8_t encoding) {
    std::vector<std::vector<int32_t>> blocks;
    const Eigen::Vector3i nb = (dims_.array() + 7) / 8;
    for (int bz = 0; bz < nb.z(); ++bz)
      for (int by = 0; by < nb.y(); ++by)
        for (int bx = 0; bx < nb.x(); ++bx) blocks.push_back({bx, by, bz});
    const int num_chunks =
        (static_cast<int>(blocks.size()) + blocks_per_chunk - 1) / blocks_per_chunk;
    std::vector<map3d_chunk_t> chunks;
    ++snapshot_id_;
    for (int c = 0; c < num_chunks; ++c) {
      map3d_chunk_t m{};
      m.utime = seq_ * 1000;
      m.snapshot_id = snapshot_id_;
      m.map_seq = seq_;
      m.chunk_index = c;
      m.num_chunks = num_chunks;
      for (int a = 0; a < 3; ++a) {
        m.origin_m[a] = origin_m[a];
        m.dims[a] = dims_[a];
      }
      m.resolution_m = resolution_m;
      m.p_init = kPInit;
      m.block_edge = 8;
      m.encoding = encoding;
      std::vector<float> raw;
      for (size_t b = static_cast<size_t>(c) * blocks_per_chunk;
           b < std::min(blocks.size(), static_cast<size_t>(c + 1) * blocks_per_chunk); ++b) {
        m.block_index.push_back(blocks[b]);
        for (int i = 0; i < 512; ++i) {
          const int x = blocks[b][0] * 8 + i % 8, y = blocks[b][1] * 8 + (i / 8) % 8,
                    z = blocks[b][2] * 8 + i / 64;
          const bool inside = x < dims_.x() && y < dims_.y() && z < dims_.z();
          // Padding beyond dims: a high value that a correct reader ignores.
          raw.push_back(inside ? p_[Index(x, y, z)] : 0.99f);
        }
      }
      m.num_blocks = static_cast<int32_t>(m.block_index.size());
      EncodeMapChunkCells(raw, encoding, 1, &m);
      chunks.push_back(std::move(m));
    }
    published_ = p_;
    last_published_seq_ = seq_;
    return chunks;
  }

  map3d_delta_t Delta() {
    map3d_delta_t m{};
    m.utime = seq_ * 1000;
    m.seq = seq_;
    m.prev_seq = last_published_seq_;
    m.base_snapshot_id = snapshot_id_;
    for (int a = 0; a < 3; ++a) m.origin_m[a] = origin_m[a];
    m.resolution_m = resolution_m;
    for (int z = 0; z < dims_.z(); ++z)
      for (int y = 0; y < dims_.y(); ++y)
        for (int x = 0; x < dims_.x(); ++x) {
          const size_t i = Index(x, y, z);
          if (p_[i] == published_[i]) continue;
          m.cells.push_back({x, y, z});
          m.probabilities.push_back(p_[i]);
        }
    m.num_cells = static_cast<int32_t>(m.cells.size());
    published_ = p_;
    last_published_seq_ = seq_;
    return m;
  }

  MapReplica MakeReplica() const { return MapReplica(origin_m, resolution_m, dims_, kPInit); }

 private:
  size_t Index(int x, int y, int z) const {
    return static_cast<size_t>(x + dims_.x() * (y + dims_.y() * z));
  }
  Eigen::Vector3i dims_;
  std::vector<float> p_;
  std::vector<float> published_;
  std::mt19937 rng_;
  int64_t seq_{0};
  int64_t last_published_seq_{0};
  int64_t snapshot_id_{0};
};

// The oracle: the replica's cells above the threshold, with their expected bytes.
CellValues OccupiedOf(const MapReplica& replica) {
  CellValues out;
  const Eigen::Vector3i& d = replica.dims();
  for (int z = 0; z < d.z(); ++z)
    for (int y = 0; y < d.y(); ++y)
      for (int x = 0; x < d.x(); ++x) {
        const int q = ExpectedQ(replica.At(x, y, z));
        if (q > 0) out[{x, y, z}] = q;
      }
  return out;
}

ViewerSceneConfig SceneConfig() {
  ViewerSceneConfig c;
  c.occupied_threshold = kThreshold;
  return c;
}

// The main claim: snapshot + update frames rebuild the replica's occupied set, for a page that
// was there from the start and for one that joins late; periodic map snapshots in between
// (with changes no delta carried) are folded into the updates.
TEST(VoxelStream, SnapshotPlusUpdatesEqualTheReplicasOccupiedSet) {
  FakeMapper mapper(Eigen::Vector3i(21, 13, 10), 7);
  MapReplica replica = mapper.MakeReplica();
  ViewerScene scene(SceneConfig());
  std::string error;
  mapper.Change(300);
  for (const auto& chunk : mapper.Snapshot(2, map3d_chunk_t::ENCODING_ZLIB_FLOAT32)) {
    ASSERT_TRUE(replica.Apply(chunk, &error)) << error;
    ASSERT_TRUE(scene.OnMapChunk(chunk, &error)) << error;
  }
  Page early;
  early.Apply(scene.SnapshotFrames());
  (void)scene.TakeUpdateFrames();  // the snapshot already holds these changes
  Page late;
  int compared = 0;
  for (int step = 1; step <= 60; ++step) {
    mapper.Change(40);
    if (step % 17 == 0) {  // a periodic snapshot, alternately uncompressed
      mapper.Change(25);   // changes that only the snapshot carries
      const int8_t encoding =
          step % 2 ? map3d_chunk_t::ENCODING_FLOAT32 : map3d_chunk_t::ENCODING_ZLIB_FLOAT32;
      for (const auto& chunk : mapper.Snapshot(3, encoding)) {
        ASSERT_TRUE(replica.Apply(chunk, &error)) << error;
        ASSERT_TRUE(scene.OnMapChunk(chunk, &error)) << error;
      }
    } else {
      const map3d_delta_t delta = mapper.Delta();
      ASSERT_TRUE(replica.Apply(delta, &error)) << error;
      ASSERT_TRUE(scene.OnMapDelta(delta, &error)) << error;
    }
    if (step % 3 != 0) continue;  // updates coalesce several map deltas
    const std::vector<ViewerFrame> update = scene.TakeUpdateFrames();
    early.Apply(update);
    if (step > 30) late.Apply(update);
    if (step == 30) late.Apply(scene.SnapshotFrames());  // a page opened late
    const CellValues expected = OccupiedOf(replica);
    ASSERT_EQ(early.cells, expected) << "step " << step;
    if (step >= 30) {
      ASSERT_EQ(late.cells, expected) << "step " << step;
    }
    EXPECT_EQ(early.map_seq, replica.seq());
    EXPECT_EQ(scene.voxels().occupied_count(), expected.size());
    ++compared;
  }
  EXPECT_EQ(compared, 20);
  EXPECT_EQ(early.snapshots, 1);
  EXPECT_GT(early.deltas, 10);
  EXPECT_EQ(late.snapshots, 1);
  EXPECT_GT(OccupiedOf(replica).size(), 200u);  // the comparison is not of empty sets
}

// A cell that rises above the threshold and falls back between two updates is not sent; one
// whose byte does not change is not sent either.
TEST(VoxelStream, ChangesBetweenTwoUpdatesCoalesce) {
  VoxelStream stream(kThreshold);
  map3d_chunk_t chunk{};
  chunk.num_chunks = 1;
  chunk.resolution_m = 0.1;
  chunk.block_edge = 8;
  chunk.p_init = 0.1;
  chunk.encoding = map3d_chunk_t::ENCODING_FLOAT32;
  chunk.num_blocks = 1;
  chunk.block_index.push_back({0, 0, 0});
  std::vector<float> values(512, 0.1f);
  values[1] = 0.8f;  // cell (1, 0, 0)
  chunk.data.resize(512 * 4);
  std::memcpy(chunk.data.data(), values.data(), chunk.data.size());
  chunk.data_size = 512 * 4;
  std::string error;
  ASSERT_TRUE(stream.Apply(chunk, &error)) << error;
  EXPECT_TRUE(stream.TakeChanges().reset);  // the first lattice: everything, with reset
  auto delta = [](int64_t seq, std::vector<std::pair<std::vector<int32_t>, float>> cells) {
    map3d_delta_t d{};
    d.seq = seq;
    d.prev_seq = seq - 1;
    d.resolution_m = 0.1;
    for (const auto& [c, p] : cells) {
      d.cells.push_back(c);
      d.probabilities.push_back(p);
    }
    d.num_cells = static_cast<int32_t>(d.cells.size());
    return d;
  };
  ASSERT_TRUE(stream.Apply(delta(1, {{{2, 0, 0}, 0.9f}, {{1, 0, 0}, 0.8001f}}), &error)) << error;
  ASSERT_TRUE(stream.Apply(delta(2, {{{2, 0, 0}, 0.2f}, {{3, 0, 0}, 0.7f}}), &error)) << error;
  const VoxelChanges changes = stream.TakeChanges();
  EXPECT_FALSE(changes.reset);
  ASSERT_EQ(changes.entries.size(), 1u);  // only cell 3; 2 came and went, 1 kept its byte
  EXPECT_EQ(changes.entries[0].x, 3);
  EXPECT_EQ(changes.entries[0].q,
            ExpectedQ(static_cast<double>(0.7f)));  // the message holds a float
  EXPECT_TRUE(stream.TakeChanges().entries.empty());
  EXPECT_EQ(stream.occupied_count(), 2u);
}

// A lost delta leaves the copy stale (no update is made from later deltas) until the next
// snapshot, after which the page again equals the replica.
TEST(VoxelStream, ALostDeltaIsStaleUntilTheNextSnapshot) {
  FakeMapper mapper(Eigen::Vector3i(16, 16, 8), 11);
  MapReplica replica = mapper.MakeReplica();
  ViewerScene scene(SceneConfig());
  std::string error;
  mapper.Change(200);
  for (const auto& chunk : mapper.Snapshot(4, map3d_chunk_t::ENCODING_ZLIB_FLOAT32)) {
    ASSERT_TRUE(replica.Apply(chunk, &error));
    ASSERT_TRUE(scene.OnMapChunk(chunk, &error));
  }
  Page page;
  page.Apply(scene.SnapshotFrames());
  (void)scene.TakeUpdateFrames();
  mapper.Change(30);
  (void)mapper.Delta();  // lost
  mapper.Change(30);
  EXPECT_FALSE(scene.OnMapDelta(mapper.Delta(), &error));
  EXPECT_FALSE(scene.voxels().current());
  mapper.Change(30);
  EXPECT_FALSE(scene.OnMapDelta(mapper.Delta(), &error)) << "still stale";
  for (const auto& chunk : mapper.Snapshot(4, map3d_chunk_t::ENCODING_ZLIB_FLOAT32)) {
    ASSERT_TRUE(replica.Apply(chunk, &error));
    ASSERT_TRUE(scene.OnMapChunk(chunk, &error));
  }
  EXPECT_TRUE(scene.voxels().current());
  page.Apply(scene.TakeUpdateFrames());
  EXPECT_EQ(page.cells, OccupiedOf(replica));
}

// docs/design.md §3.3: the mapper paces a snapshot's chunks and sends deltas between them; the
// replica and the viewer's stream keep those deltas for the snapshot and end equal to the map.
TEST(VoxelStream, DeltasBetweenASnapshotsChunksFollowIt) {
  FakeMapper mapper(Eigen::Vector3i(16, 16, 8), 13);
  MapReplica replica = mapper.MakeReplica();
  ViewerScene scene(SceneConfig());
  std::string error;
  mapper.Change(200);
  for (const auto& chunk : mapper.Snapshot(4, map3d_chunk_t::ENCODING_ZLIB_FLOAT32)) {
    ASSERT_TRUE(replica.Apply(chunk, &error)) << error;
    ASSERT_TRUE(scene.OnMapChunk(chunk, &error)) << error;
  }
  mapper.Change(40);
  const std::vector<map3d_chunk_t> chunks =
      mapper.Snapshot(1, map3d_chunk_t::ENCODING_ZLIB_FLOAT32);
  ASSERT_GE(chunks.size(), 3u);
  for (size_t c = 0; c < chunks.size(); ++c) {
    ASSERT_TRUE(replica.Apply(chunks[c], &error)) << error;
    ASSERT_TRUE(scene.OnMapChunk(chunks[c], &error)) << error;
    if (c + 1 < chunks.size()) {  // a delta while the snapshot is on its way
      mapper.Change(25);
      const map3d_delta_t delta = mapper.Delta();
      EXPECT_TRUE(replica.Apply(delta, &error)) << error;
      EXPECT_TRUE(scene.OnMapDelta(delta, &error)) << error;
    }
  }
  mapper.Change(25);
  const map3d_delta_t last = mapper.Delta();
  EXPECT_TRUE(replica.Apply(last, &error)) << error;
  EXPECT_TRUE(scene.OnMapDelta(last, &error)) << error;
  EXPECT_TRUE(replica.current());
  EXPECT_TRUE(scene.voxels().current());
  EXPECT_EQ(replica.seq(), last.seq);
  EXPECT_EQ(scene.voxels().map_seq(), last.seq);
  Page page;
  page.Apply(scene.SnapshotFrames());
  EXPECT_EQ(page.cells, OccupiedOf(replica));
  // The replica equals the mapper's cells: a fresh snapshot of them rebuilds the same copy.
  MapReplica fresh = mapper.MakeReplica();
  for (const auto& chunk : mapper.Snapshot(64, map3d_chunk_t::ENCODING_ZLIB_FLOAT32)) {
    ASSERT_TRUE(fresh.Apply(chunk, &error)) << error;
  }
  EXPECT_EQ(fresh.probabilities(), replica.probabilities());
}

// A growing map (dims 0, negative block indices) reaches the page with negative cell indices.
TEST(VoxelStream, AGrowingMapWithNegativeIndicesRoundTrips) {
  map3d_chunk_t chunk{};
  chunk.num_chunks = 1;
  chunk.resolution_m = 0.05;
  chunk.block_edge = 8;
  chunk.p_init = 0.1;
  chunk.encoding = map3d_chunk_t::ENCODING_U16_ZLIB;
  chunk.block_index = {{-1, 0, -2}, {3, -4, 0}};
  chunk.num_blocks = 2;
  std::vector<uint16_t> raw(1024, static_cast<uint16_t>(0.1 * 65535));
  CellValues expected;
  std::mt19937 rng(3);
  for (int k = 0; k < 60; ++k) {
    const int b = k % 2, i = static_cast<int>(rng() % 512);
    const auto v = static_cast<uint16_t>(40000 + rng() % 25536);
    raw[static_cast<size_t>(b * 512 + i)] = v;
    const auto& bi = chunk.block_index[static_cast<size_t>(b)];
    expected[{bi[0] * 8 + i % 8, bi[1] * 8 + (i / 8) % 8, bi[2] * 8 + i / 64}] =
        ExpectedQ(static_cast<double>(static_cast<float>(v) / 65535));
  }
  uLongf packed = compressBound(2048);
  chunk.data.resize(packed);
  compress2(chunk.data.data(), &packed, reinterpret_cast<const Bytef*>(raw.data()), 2048, 1);
  chunk.data.resize(packed);
  chunk.data_size = static_cast<int32_t>(packed);
  ViewerScene scene(SceneConfig());
  std::string error;
  ASSERT_TRUE(scene.OnMapChunk(chunk, &error)) << error;
  Page page;
  page.Apply(scene.SnapshotFrames());
  EXPECT_EQ(page.cells, expected);
  EXPECT_LT(std::get<0>(page.cells.begin()->first), 0);
}

// Malformed or out-of-sequence chunks are refused with a reason, and nothing changes.
TEST(VoxelStream, MalformedChunksAreRefused) {
  VoxelStream stream(kThreshold);
  map3d_chunk_t chunk{};
  chunk.num_chunks = 2;
  chunk.chunk_index = 0;
  chunk.resolution_m = 0.1;
  chunk.block_edge = 8;
  chunk.encoding = map3d_chunk_t::ENCODING_ZLIB_FLOAT32;
  chunk.num_blocks = 1;
  chunk.block_index.push_back({0, 0, 0});
  chunk.data = {1, 2, 3, 4};  // not zlib
  chunk.data_size = 4;
  std::string error;
  EXPECT_FALSE(stream.Apply(chunk, &error));
  EXPECT_NE(error.find("does not inflate"), std::string::npos) << error;
  chunk.encoding = 42;
  EXPECT_FALSE(stream.Apply(chunk, &error));
  chunk.encoding = map3d_chunk_t::ENCODING_FLOAT32;
  chunk.data.assign(512 * 4, 0);
  chunk.data_size = 512 * 4;
  chunk.chunk_index = 1;  // chunk 0 never arrived
  EXPECT_FALSE(stream.Apply(chunk, &error));
  EXPECT_NE(error.find("out of sequence"), std::string::npos) << error;
  chunk.block_edge = 0;
  EXPECT_FALSE(stream.Apply(chunk, &error));
  EXPECT_FALSE(stream.has_snapshot());
  map3d_delta_t delta{};
  EXPECT_FALSE(stream.Apply(delta, &error));  // no snapshot yet
  EXPECT_EQ(stream.occupied_count(), 0u);
}

// A chunk whose block index times its edge overflows int (2^28 x 8) is refused by the codec's
// range check before any cell index is computed (it was undefined behaviour, caught by UBSan in
// tests/fuzz/lcm_fuzz.cc).
TEST(VoxelStream, BlockIndexOutsideTheCellRangeIsRefused) {
  VoxelStream stream(kThreshold);
  map3d_chunk_t chunk{};
  chunk.num_chunks = 1;
  chunk.resolution_m = 0.1;
  chunk.block_edge = 8;
  chunk.num_blocks = 1;
  chunk.block_index.push_back({1 << 28, 0, 0});
  EncodeMapChunkCells(std::vector<float>(512, 0.9f), map3d_chunk_t::ENCODING_FLOAT32, 0, &chunk);
  std::string error;
  EXPECT_FALSE(stream.Apply(chunk, &error));
  EXPECT_NE(error.find("outside the cell range"), std::string::npos) << error;
  EXPECT_FALSE(stream.has_snapshot());
}

// The byte of a probability, at the edges.
TEST(VoxelStream, QuantizationFollowsTheProtocol) {
  EXPECT_EQ(QuantizeProbability(0.5, 0.5), 0);
  EXPECT_EQ(QuantizeProbability(0.5000001, 0.5), 128);
  EXPECT_EQ(QuantizeProbability(1.0, 0.5), 255);
  EXPECT_EQ(QuantizeProbability(0.001, 0.0), 1);  // occupied is never sent as 0
  EXPECT_EQ(QuantizeProbability(std::nan(""), 0.5), 0);
}

}  // namespace
}  // namespace kestrel

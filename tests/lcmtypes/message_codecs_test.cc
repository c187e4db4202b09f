// The payload codecs (lcmtypes/message_codecs.h): round trips for every encoding, the bytes of
// the little-endian layout written out by hand, and every malformed payload named, not thrown.
#include "lcmtypes/message_codecs.h"

#include <zlib.h>

#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>

#include "tests/lcmtypes/allocation_watch.h"

namespace kestrel {
namespace {

using testing::LargestAllocation;

depth_image_t Image(int width, int height) {
  depth_image_t m{};
  m.width = width;
  m.height = height;
  return m;
}

TEST(DepthPixels, RoundTripEveryEncodingAndLittleEndianBytes) {
  const std::vector<uint16_t> counts = {0x0102, 0, 65535, 4000, 1, 0x8000};
  for (int8_t e : {depth_image_t::ENCODING_RAW_U16, depth_image_t::ENCODING_ZLIB_U16}) {
    depth_image_t m = Image(3, 2);
    EncodeDepthPixels(counts, e, 6, &m);
    EXPECT_EQ(m.encoding, e);
    EXPECT_EQ(m.data_size, static_cast<int32_t>(m.data.size()));
    std::vector<uint16_t> back;
    EXPECT_EQ(DecodeDepthPixels(m, &back), "");
    EXPECT_EQ(back, counts);
  }
  depth_image_t raw = Image(3, 2);
  EncodeDepthPixels(counts, depth_image_t::ENCODING_RAW_U16, 0, &raw);
  EXPECT_EQ(raw.data[0], 0x02);  // low byte first
  EXPECT_EQ(raw.data[1], 0x01);
  EXPECT_EQ(raw.data[11], 0x80);
}

TEST(DepthPixels, MalformedPayloadsAreNamed) {
  const std::vector<uint16_t> counts(6, 1000);
  depth_image_t m = Image(3, 2);
  EncodeDepthPixels(counts, depth_image_t::ENCODING_RAW_U16, 0, &m);
  std::vector<uint16_t> out;
  depth_image_t wrong_size = m;
  wrong_size.width = 4;
  EXPECT_NE(DecodeDepthPixels(wrong_size, &out).find("needs 16"), std::string::npos);
  EXPECT_TRUE(out.empty());
  depth_image_t zero = m;
  zero.height = 0;
  EXPECT_NE(DecodeDepthPixels(zero, &out).find("image size 3x0"), std::string::npos);
  depth_image_t huge = m;
  huge.width = 9000;
  EXPECT_NE(DecodeDepthPixels(huge, &out).find("image size"), std::string::npos);
  depth_image_t unknown = m;
  unknown.encoding = 7;
  EXPECT_NE(DecodeDepthPixels(unknown, &out).find("unknown encoding 7"), std::string::npos);
  depth_image_t garbage = m;
  garbage.encoding = depth_image_t::ENCODING_ZLIB_U16;  // raw bytes are not zlib
  EXPECT_NE(DecodeDepthPixels(garbage, &out).find("does not inflate"), std::string::npos);
  depth_image_t short_zlib = Image(3, 3);  // the zlib data holds 6 pixels, not 9
  EncodeDepthPixels(counts, depth_image_t::ENCODING_ZLIB_U16, 1, &short_zlib);
  EXPECT_NE(DecodeDepthPixels(short_zlib, &out).find("does not inflate"), std::string::npos);
  EXPECT_THROW(EncodeDepthPixels(counts, 5, 1, &m), std::invalid_argument);
}

// zlib bytes inflate, with zlib itself, to the raw encoding's bytes.
TEST(DepthPixels, ZlibInflatesToRaw) {
  const std::vector<uint16_t> counts = {0x0102, 0xfffe, 0, 2111};
  depth_image_t raw = Image(2, 2), z = Image(2, 2);
  EncodeDepthPixels(counts, depth_image_t::ENCODING_RAW_U16, 0, &raw);
  EXPECT_EQ(raw.data, (std::vector<uint8_t>{0x02, 0x01, 0xfe, 0xff, 0x00, 0x00, 0x3f, 0x08}));
  EncodeDepthPixels(counts, depth_image_t::ENCODING_ZLIB_U16, 6, &z);
  std::vector<uint8_t> inflated(64);
  uLongf size = inflated.size();
  ASSERT_EQ(uncompress(inflated.data(), &size, z.data.data(), z.data.size()), Z_OK);
  inflated.resize(size);
  EXPECT_EQ(inflated, raw.data);
}

TEST(DepthPixels, RoundTripsRandomImagesAndRejectsCorruptZlib) {
  std::mt19937 rng(11);
  for (const int8_t e : {depth_image_t::ENCODING_RAW_U16, depth_image_t::ENCODING_ZLIB_U16}) {
    for (int trial = 0; trial < 20; ++trial) {
      depth_image_t m = Image(1 + static_cast<int>(rng() % 80), 1 + static_cast<int>(rng() % 60));
      std::vector<uint16_t> counts(static_cast<size_t>(m.width) * m.height);
      for (auto& c : counts) c = static_cast<uint16_t>(rng() % 3 == 0 ? 0 : rng());
      EncodeDepthPixels(counts, e, static_cast<int>(rng() % 10), &m);
      std::vector<uint16_t> back;
      ASSERT_EQ(DecodeDepthPixels(m, &back), "");
      EXPECT_EQ(back, counts);
      if (e == depth_image_t::ENCODING_ZLIB_U16) {
        m.data[m.data.size() / 2] ^= 0x5a;
        EXPECT_NE(DecodeDepthPixels(m, &back), "");
      }
    }
  }
}

map3d_chunk_t Chunk(int blocks, int edge) {
  map3d_chunk_t c{};
  c.block_edge = edge;
  c.num_blocks = blocks;
  c.block_index.assign(static_cast<size_t>(blocks), {0, 0, 0});
  return c;
}

TEST(MapChunkCells, RoundTripEveryEncoding) {
  std::vector<float> p(2 * 8);  // two blocks of edge 2
  for (size_t i = 0; i < p.size(); ++i) p[i] = static_cast<float>(i) / 15.0f;
  for (int8_t e : {map3d_chunk_t::ENCODING_FLOAT32, map3d_chunk_t::ENCODING_ZLIB_FLOAT32,
                   map3d_chunk_t::ENCODING_U16_ZLIB}) {
    map3d_chunk_t c = Chunk(2, 2);
    EncodeMapChunkCells(p, e, 1, &c);
    std::vector<float> back;
    ASSERT_EQ(DecodeMapChunkCells(c, &back), "") << int{e};
    ASSERT_EQ(back.size(), p.size());
    for (size_t i = 0; i < p.size(); ++i) {
      if (e == map3d_chunk_t::ENCODING_U16_ZLIB) {
        EXPECT_NEAR(back[i], p[i], 0.5 / 65535 + 1e-7) << i;  // quantised to 1/65535
      } else {
        EXPECT_EQ(back[i], p[i]) << i;  // bit for bit
      }
    }
  }
  map3d_chunk_t plain = Chunk(1, 1);
  EncodeMapChunkCells({1.0f}, map3d_chunk_t::ENCODING_FLOAT32, 0, &plain);
  EXPECT_EQ(plain.data, (std::vector<uint8_t>{0x00, 0x00, 0x80, 0x3f}));  // 1.0f, little-endian
}

TEST(MapChunkCells, MalformedPayloadsAreNamed) {
  std::vector<float> out;
  map3d_chunk_t c = Chunk(2, 2);
  EncodeMapChunkCells(std::vector<float>(16, 0.5f), map3d_chunk_t::ENCODING_ZLIB_FLOAT32, 1, &c);
  map3d_chunk_t edge = c;
  edge.block_edge = 0;
  EXPECT_NE(DecodeMapChunkCells(edge, &out).find("block edge 0"), std::string::npos);
  map3d_chunk_t count = c;
  count.num_blocks = 3;
  EXPECT_NE(DecodeMapChunkCells(count, &out).find("does not match"), std::string::npos);
  map3d_chunk_t more_blocks = c;  // index and count agree, but the data holds two blocks
  more_blocks.num_blocks = 3;
  more_blocks.block_index.push_back({1, 0, 0});
  EXPECT_NE(DecodeMapChunkCells(more_blocks, &out).find("does not inflate"), std::string::npos);
  map3d_chunk_t raw = c;
  raw.encoding = map3d_chunk_t::ENCODING_FLOAT32;  // zlib bytes read as floats: wrong size
  EXPECT_NE(DecodeMapChunkCells(raw, &out).find("blocks need 64"), std::string::npos);
  map3d_chunk_t unknown = c;
  unknown.encoding = 9;
  EXPECT_NE(DecodeMapChunkCells(unknown, &out).find("unknown encoding 9"), std::string::npos);
  EXPECT_TRUE(out.empty());
}

TEST(MapDelta, ChecksCountsResolutionAndProbabilities) {
  map3d_delta_t d{};
  d.resolution_m = 0.075;
  d.num_cells = 2;
  d.cells = {{0, 0, 0}, {1, 2, 3}};
  d.probabilities = {0.0f, 1.0f};
  EXPECT_EQ(CheckMapDelta(d), "");
  map3d_delta_t count = d;
  count.num_cells = 3;
  EXPECT_NE(CheckMapDelta(count).find("num_cells 3"), std::string::npos);
  map3d_delta_t arrays = d;
  arrays.probabilities.pop_back();
  EXPECT_NE(CheckMapDelta(arrays), "");
  map3d_delta_t nan = d;
  nan.probabilities[1] = std::nanf("");
  EXPECT_NE(CheckMapDelta(nan).find("outside [0, 1]"), std::string::npos);
  map3d_delta_t big = d;
  big.probabilities[0] = 1.5f;
  EXPECT_NE(CheckMapDelta(big), "");
  map3d_delta_t resolution = d;
  resolution.resolution_m = 0.0;
  EXPECT_NE(CheckMapDelta(resolution).find("resolution"), std::string::npos);
}

// The packed delta (ENCODING_ZLIB_CELLS), byte for byte as map3d_delta_t.lcm describes it: the
// zigzag varints of the coordinate differences, then the float32s byte plane by byte plane.
TEST(MapDelta, PackedCellsAreTheDocumentedBytes) {
  MapDeltaCells in;
  in.cells = {{1, 2, 3}, {0, 2, 3}, {-64, 2, 3}};
  in.probabilities = {0.5f, 1.0f, 0.0f};
  map3d_delta_t d{};
  d.resolution_m = 0.075;
  EncodeMapDeltaCells(in, map3d_delta_t::ENCODING_ZLIB_CELLS, 6, &d);
  EXPECT_EQ(d.num_cells, 0);
  EXPECT_TRUE(d.cells.empty());
  EXPECT_EQ(d.num_packed_cells, 3);
  EXPECT_EQ(d.data_size, static_cast<int32_t>(d.data.size()));
  std::vector<uint8_t> raw(64);
  uLongf size = raw.size();
  ASSERT_EQ(uncompress(raw.data(), &size, d.data.data(), d.data.size()), Z_OK);
  raw.resize(size);
  // 1 -> 2, 2 -> 4, 3 -> 6; -1 -> 1, 0, 0; -64 -> 127, 0, 0. 0.5f = 0x3f000000, 1.0f = 0x3f800000.
  const std::vector<uint8_t> expected = {2, 4,    6, 1,    0,    0, 127, 0, 0,  // indices
                                         0, 0,    0, 0,    0,    0,   // first and second bytes
                                         0, 0x80, 0, 0x3f, 0x3f, 0};  // third and fourth
  EXPECT_EQ(raw, expected);
  MapDeltaCells out;
  ASSERT_EQ(DecodeMapDelta(d, &out), "");
  EXPECT_EQ(out.cells, in.cells);
  EXPECT_EQ(out.probabilities, in.probabilities);
}

// Both encodings give back exactly the cells and floats put in (every bit), over far-apart
// indices, the map's index limits and probabilities that are not round numbers; the packed one is
// far smaller than the arrays for cells in a map's order.
TEST(MapDelta, EncodingsRoundTripExactly) {
  MapDeltaCells in;
  uint32_t state = 12345;
  auto next = [&state] { return state = state * 1664525u + 1013904223u; };
  for (int z = 0; z < 8; ++z) {
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x) {
        in.cells.push_back({100 + x, -40 + y, z});
        in.probabilities.push_back(static_cast<float>(next() % 1000000) / 1e6f);
      }
    }
  }
  in.cells.push_back({(1 << 23) - 1, -(1 << 23) + 1, 0});
  in.probabilities.push_back(std::nextafter(1.0f, 0.0f));
  for (const int8_t encoding :
       {map3d_delta_t::ENCODING_CELLS, map3d_delta_t::ENCODING_ZLIB_CELLS}) {
    map3d_delta_t d{};
    d.resolution_m = 0.075;
    EncodeMapDeltaCells(in, encoding, 1, &d);
    std::vector<uint8_t> bytes(static_cast<size_t>(d.getEncodedSize()));
    ASSERT_EQ(d.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
              static_cast<int>(bytes.size()));
    map3d_delta_t back{};
    ASSERT_EQ(back.decode(bytes.data(), 0, static_cast<int>(bytes.size())),
              static_cast<int>(bytes.size()));
    MapDeltaCells out;
    ASSERT_EQ(DecodeMapDelta(back, &out), "") << int{encoding};
    EXPECT_EQ(out.cells, in.cells);
    ASSERT_EQ(out.probabilities.size(), in.probabilities.size());
    for (size_t i = 0; i < in.probabilities.size(); ++i) {
      ASSERT_EQ(std::memcmp(&out.probabilities[i], &in.probabilities[i], 4), 0) << i;
    }
    std::printf("encoding %d: %zu cells in %zu bytes\n", int{encoding}, in.cells.size(),
                bytes.size());
    if (encoding == map3d_delta_t::ENCODING_ZLIB_CELLS) {
      EXPECT_LT(bytes.size(), in.cells.size() * 16 / 2) << "less than half the arrays' bytes";
    }
  }
  EXPECT_THROW(EncodeMapDeltaCells(in, 7, 1, nullptr), std::invalid_argument);
}

TEST(MapDelta, PackedCellsThatDoNotAddUpAreRefused) {
  MapDeltaCells in;
  in.cells = {{1, 2, 3}, {4, 5, 6}};
  in.probabilities = {0.25f, 0.75f};
  map3d_delta_t d{};
  d.resolution_m = 0.075;
  EncodeMapDeltaCells(in, map3d_delta_t::ENCODING_ZLIB_CELLS, 1, &d);
  MapDeltaCells out;
  ASSERT_EQ(DecodeMapDelta(d, &out), "");
  map3d_delta_t fewer = d;
  fewer.num_packed_cells = 1;  // the payload holds two: bytes left over
  EXPECT_NE(DecodeMapDelta(fewer, &out), "");
  map3d_delta_t more = d;
  more.num_packed_cells = 3;
  EXPECT_NE(DecodeMapDelta(more, &out), "");
  map3d_delta_t huge = d;
  huge.num_packed_cells = 100000000;  // refused before anything that size is allocated
  EXPECT_NE(DecodeMapDelta(huge, &out).find("cannot come from"), std::string::npos);
  map3d_delta_t cut = d;
  cut.data.resize(cut.data.size() - 3);
  cut.data_size = static_cast<int32_t>(cut.data.size());
  EXPECT_NE(DecodeMapDelta(cut, &out).find("do not inflate"), std::string::npos);
  map3d_delta_t both = d;
  both.num_cells = 1;
  both.cells = {{0, 0, 0}};
  both.probabilities = {0.5f};
  EXPECT_NE(DecodeMapDelta(both, &out).find("cells in the arrays"), std::string::npos);
  map3d_delta_t unknown = d;
  unknown.encoding = 5;
  EXPECT_NE(DecodeMapDelta(unknown, &out).find("unknown encoding 5"), std::string::npos);
  MapDeltaCells far;
  far.cells = {{1 << 23, 0, 0}};
  far.probabilities = {0.5f};
  map3d_delta_t outside{};
  outside.resolution_m = 0.075;
  EncodeMapDeltaCells(far, map3d_delta_t::ENCODING_ZLIB_CELLS, 1, &outside);
  EXPECT_NE(DecodeMapDelta(outside, &out).find("outside"), std::string::npos);
  MapDeltaCells bad;
  bad.cells = {{0, 0, 0}};
  bad.probabilities = {std::nanf("")};
  map3d_delta_t nan{};
  nan.resolution_m = 0.075;
  EncodeMapDeltaCells(bad, map3d_delta_t::ENCODING_ZLIB_CELLS, 1, &nan);
  EXPECT_NE(DecodeMapDelta(nan, &out).find("outside [0, 1]"), std::string::npos);
}

// A compressed payload's header claims the size; a few bytes of zlib cannot hold more than 1032
// times their size (deflate's best ratio), so a decoder refuses a bigger claim before it
// allocates it: a 16-byte message may not make a consumer allocate 128 MiB (depth) or 64 MiB
// (snapshot cells).
TEST(CompressedPayloads, ClaimsBeyondDeflatesRatioAreRefusedBeforeAllocating) {
  depth_image_t depth = Image(8192, 8192);
  depth.encoding = depth_image_t::ENCODING_ZLIB_U16;
  depth.data.assign(16, 0x78);
  depth.data_size = 16;
  std::vector<uint16_t> counts;
  std::string error;
  EXPECT_LT(LargestAllocation([&] { error = DecodeDepthPixels(depth, &counts); }), size_t{1} << 20);
  EXPECT_NE(error.find("cannot inflate"), std::string::npos) << error;
  EXPECT_TRUE(counts.empty());

  map3d_chunk_t chunk{};
  chunk.block_edge = 64;
  chunk.num_blocks = 64;
  chunk.block_index.assign(64, std::vector<int32_t>(3, 0));
  chunk.data.assign(16, 0x78);
  chunk.data_size = 16;
  std::vector<float> cells;
  for (int8_t e : {map3d_chunk_t::ENCODING_ZLIB_FLOAT32, map3d_chunk_t::ENCODING_U16_ZLIB}) {
    chunk.encoding = e;
    EXPECT_LT(LargestAllocation([&] { error = DecodeMapChunkCells(chunk, &cells); }),
              size_t{1} << 20);
    EXPECT_NE(error.find("cannot inflate"), std::string::npos) << error;
  }
}

// A block whose cells lie outside a map's index range (-2^23, 2^23) is refused, so that a
// consumer computing block index x edge + offset in int cannot overflow (it did in MapReplica and
// VoxelStream for an index of 2^28 at edge 8); the range's last blocks are accepted.
TEST(MapChunkCells, BlockIndicesOutsideTheCellRangeAreRefused) {
  map3d_chunk_t c = Chunk(1, 8);
  EncodeMapChunkCells(std::vector<float>(512, 0.5f), map3d_chunk_t::ENCODING_FLOAT32, 0, &c);
  std::vector<float> cells;
  for (const std::vector<int32_t>& index : std::vector<std::vector<int32_t>>{
           {1 << 28, 0, 0}, {0, -(1 << 20), 0}, {0, 0, 1 << 20}, {INT32_MIN, 0, 0}}) {
    c.block_index = {index};
    const std::string error = DecodeMapChunkCells(c, &cells);
    EXPECT_NE(error.find("outside the cell range"), std::string::npos) << error;
    EXPECT_TRUE(cells.empty());
  }
  c.block_index = {{(1 << 20) - 1, -(1 << 20) + 1, 0}};
  EXPECT_EQ(DecodeMapChunkCells(c, &cells), "");
  c.block_index = {{0, 0}};
  EXPECT_NE(DecodeMapChunkCells(c, &cells).find("not 3"), std::string::npos);
}

// The bound never refuses real data: the most compressible image (all zeros) still decodes.
TEST(CompressedPayloads, MostCompressibleImageStillDecodes) {
  const std::vector<uint16_t> zeros(size_t{4096} * 4096, 0);
  depth_image_t m = Image(4096, 4096);
  EncodeDepthPixels(zeros, depth_image_t::ENCODING_ZLIB_U16, 9, &m);
  std::vector<uint16_t> back;
  EXPECT_EQ(DecodeDepthPixels(m, &back), "");
  EXPECT_EQ(back, zeros);
}

// The deltas kept while a snapshot's chunks arrive: those of the snapshot's mapper that follow
// it or the last one kept, in order; a new snapshot forgets them; Take empties the buffer.
TEST(SnapshotDeltaBuffer, KeepsTheDeltasThatFollowTheSnapshot) {
  const auto delta = [](int64_t epoch, int64_t prev_seq, int64_t seq) {
    map3d_delta_t d{};
    d.epoch = epoch;
    d.prev_seq = prev_seq;
    d.seq = seq;
    return d;
  };
  SnapshotDeltaBuffer b;
  b.Begin(7, 10);
  EXPECT_FALSE(b.Keep(delta(8, 10, 11)));  // another mapper
  EXPECT_FALSE(b.Keep(delta(7, 9, 10)));   // before the snapshot
  EXPECT_FALSE(b.Keep(delta(7, 11, 12)));  // a gap
  EXPECT_TRUE(b.Keep(delta(7, 10, 11)));
  EXPECT_FALSE(b.Keep(delta(7, 10, 11)));  // again
  EXPECT_TRUE(b.Keep(delta(7, 11, 13)));
  const std::vector<map3d_delta_t> kept = b.Take();
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].seq, 11);
  EXPECT_EQ(kept[1].seq, 13);
  EXPECT_TRUE(b.Take().empty());
  EXPECT_TRUE(b.Keep(delta(7, 13, 14)));  // still following the last kept
  b.Begin(7, 20);
  EXPECT_TRUE(b.Take().empty());
  EXPECT_FALSE(b.Keep(delta(7, 14, 15)));
}

}  // namespace
}  // namespace kestrel

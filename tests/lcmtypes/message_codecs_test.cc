// The payload codecs (lcmtypes/message_codecs.h): round trips for every encoding, the bytes of
// the little-endian layout written out by hand, and every malformed payload named, not thrown.
#include "lcmtypes/message_codecs.h"

#include <zlib.h>

#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstdlib>
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

#include "lcmtypes/message_codecs.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace kestrel {
namespace {

constexpr int kMaxImageSide = 8192;
constexpr int kMaxBlockEdge = 64;
// Cell indices of a map lie in (-2^23, 2^23) per axis (GridGeometry::kUnboundedCells, mapping/).
constexpr int64_t kMaxCellIndex = int64_t{1} << 23;

std::vector<uint8_t> Deflate(const std::vector<uint8_t>& raw, int level) {
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<uint8_t> out(size);
  const int rc = compress2(out.data(), &size, raw.data(), static_cast<uLong>(raw.size()), level);
  if (rc != Z_OK) throw std::runtime_error("zlib compress2 failed: " + std::to_string(rc));
  out.resize(size);
  return out;
}

// Deflate's best ratio: 258 bytes from a match of two bits at most, 1032:1 (zlib's FAQ).
constexpr size_t kMaxInflateRatio = 1032;

// True if `packed` could inflate to `size` bytes at all: the bound is checked before the output
// is allocated, so a tiny message cannot make a decoder allocate what its header claims.
bool CanInflateTo(const std::vector<uint8_t>& packed, size_t size) {
  return size / kMaxInflateRatio <= packed.size();
}

// True if `packed` inflates to exactly raw->size() bytes.
bool InflateExactly(const std::vector<uint8_t>& packed, std::vector<uint8_t>* raw) {
  uLongf size = static_cast<uLongf>(raw->size());
  return uncompress(raw->data(), &size, packed.data(), static_cast<uLong>(packed.size())) == Z_OK &&
         size == raw->size();
}

std::vector<uint8_t> U16Bytes(const std::vector<uint16_t>& values) {
  std::vector<uint8_t> bytes(values.size() * 2);
  for (size_t i = 0; i < values.size(); ++i) {
    bytes[2 * i] = static_cast<uint8_t>(values[i] & 0xff);
    bytes[2 * i + 1] = static_cast<uint8_t>(values[i] >> 8);
  }
  return bytes;
}

uint16_t U16At(const std::vector<uint8_t>& bytes, size_t i) {
  return static_cast<uint16_t>(bytes[2 * i] | (bytes[2 * i + 1] << 8));
}

std::vector<uint8_t> FloatBytes(const std::vector<float>& values) {
  std::vector<uint8_t> bytes(values.size() * 4);
  for (size_t i = 0; i < values.size(); ++i) {
    uint32_t u = 0;
    std::memcpy(&u, &values[i], 4);
    for (int b = 0; b < 4; ++b) bytes[4 * i + b] = static_cast<uint8_t>(u >> (8 * b));
  }
  return bytes;
}

float FloatAt(const std::vector<uint8_t>& bytes, size_t i) {
  uint32_t u = 0;
  for (int b = 0; b < 4; ++b) u |= static_cast<uint32_t>(bytes[4 * i + b]) << (8 * b);
  float f = 0.0f;
  std::memcpy(&f, &u, 4);
  return f;
}

}  // namespace

void EncodeDepthPixels(const std::vector<uint16_t>& counts, int8_t encoding, int zlib_level,
                       depth_image_t* msg) {
  std::vector<uint8_t> raw = U16Bytes(counts);
  if (encoding == depth_image_t::ENCODING_RAW_U16) {
    msg->data = std::move(raw);
  } else if (encoding == depth_image_t::ENCODING_ZLIB_U16) {
    msg->data = Deflate(raw, zlib_level);
  } else {
    throw std::invalid_argument("depth_image_t: unknown encoding " + std::to_string(encoding));
  }
  msg->encoding = encoding;
  msg->data_size = static_cast<int32_t>(msg->data.size());
}

std::string DecodeDepthPixels(const depth_image_t& msg, std::vector<uint16_t>* counts) {
  counts->clear();
  if (msg.width <= 0 || msg.height <= 0 || msg.width > kMaxImageSide ||
      msg.height > kMaxImageSide) {
    return "image size " + std::to_string(msg.width) + "x" + std::to_string(msg.height);
  }
  const size_t pixels = static_cast<size_t>(msg.width) * static_cast<size_t>(msg.height);
  std::vector<uint8_t> inflated;
  const std::vector<uint8_t>* raw = &msg.data;
  if (msg.encoding == depth_image_t::ENCODING_ZLIB_U16) {
    if (!CanInflateTo(msg.data, pixels * 2)) {
      return "zlib data of " + std::to_string(msg.data.size()) + " bytes cannot inflate to " +
             std::to_string(msg.width) + "x" + std::to_string(msg.height) + " pixels";
    }
    inflated.resize(pixels * 2);
    if (!InflateExactly(msg.data, &inflated)) return "zlib data does not inflate to the image size";
    raw = &inflated;
  } else if (msg.encoding != depth_image_t::ENCODING_RAW_U16) {
    return "unknown encoding " + std::to_string(msg.encoding);
  }
  if (raw->size() != pixels * 2) {
    return "raw data holds " + std::to_string(raw->size()) + " bytes, " +
           std::to_string(msg.width) + "x" + std::to_string(msg.height) + " needs " +
           std::to_string(pixels * 2);
  }
  counts->resize(pixels);
  for (size_t i = 0; i < pixels; ++i) (*counts)[i] = U16At(*raw, i);
  return "";
}

void EncodeMapChunkCells(const std::vector<float>& probabilities, int8_t encoding, int zlib_level,
                         map3d_chunk_t* chunk) {
  if (encoding == map3d_chunk_t::ENCODING_FLOAT32) {
    chunk->data = FloatBytes(probabilities);
  } else if (encoding == map3d_chunk_t::ENCODING_ZLIB_FLOAT32) {
    chunk->data = Deflate(FloatBytes(probabilities), zlib_level);
  } else if (encoding == map3d_chunk_t::ENCODING_U16_ZLIB) {
    std::vector<uint16_t> packed(probabilities.size());
    for (size_t i = 0; i < packed.size(); ++i) {
      const float p = std::min(1.0f, std::max(0.0f, probabilities[i]));
      packed[i] = static_cast<uint16_t>(std::lround(p * 65535.0f));
    }
    chunk->data = Deflate(U16Bytes(packed), zlib_level);
  } else {
    throw std::invalid_argument("map3d_chunk_t: unknown encoding " + std::to_string(encoding));
  }
  chunk->encoding = encoding;
  chunk->data_size = static_cast<int32_t>(chunk->data.size());
}

std::string DecodeMapChunkCells(const map3d_chunk_t& chunk, std::vector<float>* probabilities) {
  probabilities->clear();
  if (chunk.block_edge <= 0 || chunk.block_edge > kMaxBlockEdge) {
    return "block edge " + std::to_string(chunk.block_edge);
  }
  if (chunk.num_blocks < 0 || static_cast<size_t>(chunk.num_blocks) != chunk.block_index.size()) {
    return "num_blocks " + std::to_string(chunk.num_blocks) + " does not match its index";
  }
  const size_t edge = static_cast<size_t>(chunk.block_edge);
  for (const std::vector<int32_t>& b : chunk.block_index) {
    if (b.size() != 3) return "a block index of " + std::to_string(b.size()) + " values, not 3";
    for (const int32_t index : b) {
      // Cells of the block: [index * edge, (index + 1) * edge), inside (-2^23, 2^23).
      const int64_t first = int64_t{index} * chunk.block_edge;
      if (first <= -kMaxCellIndex || first + chunk.block_edge > kMaxCellIndex) {
        return "block index (" + std::to_string(b[0]) + ", " + std::to_string(b[1]) + ", " +
               std::to_string(b[2]) + ") outside the cell range +-2^23";
      }
    }
  }
  const size_t cells = static_cast<size_t>(chunk.num_blocks) * edge * edge * edge;
  const size_t width = chunk.encoding == map3d_chunk_t::ENCODING_U16_ZLIB ? 2 : 4;
  std::vector<uint8_t> inflated;
  const std::vector<uint8_t>* raw = &chunk.data;
  if (chunk.encoding == map3d_chunk_t::ENCODING_ZLIB_FLOAT32 ||
      chunk.encoding == map3d_chunk_t::ENCODING_U16_ZLIB) {
    if (!CanInflateTo(chunk.data, cells * width)) {
      return "data of " + std::to_string(chunk.data.size()) + " bytes (encoding " +
             std::to_string(chunk.encoding) + ") cannot inflate to its " +
             std::to_string(chunk.num_blocks) + " blocks";
    }
    inflated.resize(cells * width);
    if (!InflateExactly(chunk.data, &inflated)) {
      return "data (encoding " + std::to_string(chunk.encoding) + ") does not inflate to its " +
             std::to_string(chunk.num_blocks) + " blocks";
    }
    raw = &inflated;
  } else if (chunk.encoding != map3d_chunk_t::ENCODING_FLOAT32) {
    return "unknown encoding " + std::to_string(chunk.encoding);
  }
  if (raw->size() != cells * width) {
    return "data holds " + std::to_string(raw->size()) + " bytes, " +
           std::to_string(chunk.num_blocks) + " blocks need " + std::to_string(cells * width);
  }
  probabilities->resize(cells);
  for (size_t i = 0; i < cells; ++i) {
    (*probabilities)[i] =
        width == 2 ? static_cast<float>(U16At(*raw, i)) / 65535.0f : FloatAt(*raw, i);
  }
  return "";
}

namespace {

void PutVarint(int64_t v, std::vector<uint8_t>* out) {
  uint64_t z = (static_cast<uint64_t>(v) << 1) ^ static_cast<uint64_t>(v >> 63);  // zigzag
  while (z >= 0x80) {
    out->push_back(static_cast<uint8_t>(z | 0x80));
    z >>= 7;
  }
  out->push_back(static_cast<uint8_t>(z));
}

// Reads one zigzag varint of at most 5 bytes (an int32 difference); false at the end or if longer.
bool GetVarint(const std::vector<uint8_t>& in, size_t* pos, int64_t* v) {
  uint64_t z = 0;
  for (int shift = 0; shift < 35; shift += 7) {
    if (*pos >= in.size()) return false;
    const uint8_t b = in[(*pos)++];
    z |= static_cast<uint64_t>(b & 0x7f) << shift;
    if ((b & 0x80) == 0) {
      *v = static_cast<int64_t>(z >> 1) ^ -static_cast<int64_t>(z & 1);
      return true;
    }
  }
  return false;
}

// The most bytes one packed cell takes: three 5-byte varints and a float; the fewest: 3 + 4.
constexpr size_t kMaxPackedCellBytes = 19;
constexpr size_t kMinPackedCellBytes = 7;

}  // namespace

void EncodeMapDeltaCells(const MapDeltaCells& cells, int8_t encoding, int zlib_level,
                         map3d_delta_t* delta) {
  if (cells.cells.size() != cells.probabilities.size()) {
    throw std::invalid_argument("EncodeMapDeltaCells: cells and probabilities differ in size");
  }
  if (encoding != map3d_delta_t::ENCODING_CELLS && encoding != map3d_delta_t::ENCODING_ZLIB_CELLS) {
    throw std::invalid_argument("EncodeMapDeltaCells: unknown encoding " +
                                std::to_string(encoding));
  }
  delta->encoding = encoding;
  delta->cells.clear();
  delta->probabilities.clear();
  delta->data.clear();
  delta->num_cells = 0;
  delta->num_packed_cells = 0;
  if (encoding == map3d_delta_t::ENCODING_CELLS) {
    for (const auto& c : cells.cells) delta->cells.push_back({c[0], c[1], c[2]});
    delta->probabilities = cells.probabilities;
    delta->num_cells = static_cast<int32_t>(cells.cells.size());
  } else if (encoding == map3d_delta_t::ENCODING_ZLIB_CELLS) {
    const size_t n = cells.cells.size();
    std::vector<uint8_t> raw;
    raw.reserve(n * 8);
    std::array<int64_t, 3> previous{0, 0, 0};
    for (const auto& c : cells.cells) {
      for (int a = 0; a < 3; ++a) {
        PutVarint(int64_t{c[a]} - previous[a], &raw);
        previous[a] = c[a];
      }
    }
    const std::vector<uint8_t> floats = FloatBytes(cells.probabilities);
    for (int plane = 0; plane < 4; ++plane) {
      for (size_t i = 0; i < n; ++i) raw.push_back(floats[4 * i + plane]);
    }
    delta->data = Deflate(raw, zlib_level);
    delta->num_packed_cells = static_cast<int32_t>(n);
  }
  delta->data_size = static_cast<int32_t>(delta->data.size());
}

std::string DecodeMapDelta(const map3d_delta_t& delta, MapDeltaCells* out) {
  out->cells.clear();
  out->probabilities.clear();
  if (delta.num_cells < 0 || static_cast<size_t>(delta.num_cells) != delta.cells.size() ||
      delta.cells.size() != delta.probabilities.size()) {
    return "num_cells " + std::to_string(delta.num_cells) + " does not match its arrays";
  }
  if (delta.data_size < 0 || static_cast<size_t>(delta.data_size) != delta.data.size()) {
    return "data_size " + std::to_string(delta.data_size) + " does not match its data";
  }
  if (!(std::isfinite(delta.resolution_m) && delta.resolution_m > 0)) {
    return "resolution " + std::to_string(delta.resolution_m);
  }
  if (delta.encoding == map3d_delta_t::ENCODING_CELLS) {
    if (delta.num_packed_cells != 0 || delta.data_size != 0) {
      return "ENCODING_CELLS with packed cells or data";
    }
    for (const auto& c : delta.cells) out->cells.push_back({c[0], c[1], c[2]});
    out->probabilities = delta.probabilities;
  } else if (delta.encoding == map3d_delta_t::ENCODING_ZLIB_CELLS) {
    if (delta.num_cells != 0) return "ENCODING_ZLIB_CELLS with cells in the arrays";
    if (delta.num_packed_cells < 0) {
      return "num_packed_cells " + std::to_string(delta.num_packed_cells);
    }
    const size_t n = static_cast<size_t>(delta.num_packed_cells);
    if (!CanInflateTo(delta.data, n * kMinPackedCellBytes)) {
      return std::to_string(n) + " packed cells cannot come from " +
             std::to_string(delta.data.size()) + " bytes";
    }
    std::vector<uint8_t> raw(n * kMaxPackedCellBytes);
    uLongf size = static_cast<uLongf>(raw.size());
    if (uncompress(raw.data(), &size, delta.data.data(), static_cast<uLong>(delta.data.size())) !=
        Z_OK) {
      return "the packed cells do not inflate";
    }
    raw.resize(size);
    if (raw.size() < 4 * n) return "the packed cells are too short";
    const size_t coordinates_end = raw.size() - 4 * n;
    std::vector<uint8_t> coordinates(raw.begin(),
                                     raw.begin() + static_cast<std::ptrdiff_t>(coordinates_end));
    size_t pos = 0;
    std::array<int64_t, 3> c{0, 0, 0};
    out->cells.reserve(n);
    for (size_t i = 0; i < n; ++i) {
      for (int a = 0; a < 3; ++a) {
        int64_t d = 0;
        if (!GetVarint(coordinates, &pos, &d)) return "a packed cell index is cut short";
        c[a] += d;
        if (c[a] <= -kMaxCellIndex || c[a] >= kMaxCellIndex) {
          return "a packed cell index outside (-2^23, 2^23)";
        }
      }
      out->cells.push_back(
          {static_cast<int32_t>(c[0]), static_cast<int32_t>(c[1]), static_cast<int32_t>(c[2])});
    }
    if (pos != coordinates.size()) return "bytes left over after the packed cell indices";
    std::vector<uint8_t> floats(4 * n);
    for (int plane = 0; plane < 4; ++plane) {
      for (size_t i = 0; i < n; ++i) {
        floats[4 * i + plane] = raw[coordinates_end + plane * n + i];
      }
    }
    out->probabilities.resize(n);
    for (size_t i = 0; i < n; ++i) out->probabilities[i] = FloatAt(floats, i);
  } else {
    return "unknown encoding " + std::to_string(delta.encoding);
  }
  for (const float p : out->probabilities) {
    if (!(p >= 0.0f && p <= 1.0f)) return "a probability outside [0, 1]";
  }
  return "";
}

std::string CheckMapDelta(const map3d_delta_t& delta) {
  MapDeltaCells cells;
  return DecodeMapDelta(delta, &cells);
}

void SnapshotDeltaBuffer::Begin(int64_t epoch, int64_t map_seq) {
  epoch_ = epoch;
  tail_seq_ = map_seq;
  deltas_.clear();
}

bool SnapshotDeltaBuffer::Keep(const map3d_delta_t& delta) {
  if (delta.epoch != epoch_ || delta.prev_seq != tail_seq_ || delta.seq <= tail_seq_) return false;
  deltas_.push_back(delta);
  tail_seq_ = delta.seq;
  return true;
}

std::vector<map3d_delta_t> SnapshotDeltaBuffer::Take() {
  std::vector<map3d_delta_t> kept;
  kept.swap(deltas_);
  return kept;
}

}  // namespace kestrel

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

std::string CheckMapDelta(const map3d_delta_t& delta) {
  if (delta.num_cells < 0 || static_cast<size_t>(delta.num_cells) != delta.cells.size() ||
      delta.cells.size() != delta.probabilities.size()) {
    return "num_cells " + std::to_string(delta.num_cells) + " does not match its arrays";
  }
  if (!(std::isfinite(delta.resolution_m) && delta.resolution_m > 0)) {
    return "resolution " + std::to_string(delta.resolution_m);
  }
  for (const float p : delta.probabilities) {
    if (!(p >= 0.0f && p <= 1.0f)) return "a probability outside [0, 1]";
  }
  return "";
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

#pragma once
/// @file
/// The payload codecs of the message contract, one per message, used by every producer and
/// consumer (docs/design.md §3): depth_image_t's pixels, map3d_chunk_t's blocks and the checks of
/// map3d_delta_t. Pure functions: bytes in, values out; a decoder never throws on bad input but
/// says what is wrong, so the caller can count and log the message it drops.
///
/// Byte order: u16 and float32 payloads are little-endian whatever the host (x86-64 and the
/// Jetson's arm64 both are; the codec converts explicitly all the same).

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "kestrel/depth_image_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/map3d_delta_t.hpp"

namespace kestrel {

/// Sets msg->encoding, data and data_size from `counts` (width x height, row-major):
/// ENCODING_RAW_U16, or ENCODING_ZLIB_U16 at zlib_level (0-9). @throws std::invalid_argument on
/// an unknown encoding, std::runtime_error if zlib fails.
void EncodeDepthPixels(const std::vector<uint16_t>& counts, int8_t encoding, int zlib_level,
                       depth_image_t* msg);

/// The pixels of a depth image (width x height counts, row-major). Checks the size (positive,
/// at most 8192 a side), the encoding and that the payload holds exactly width x height pixels.
/// Returns "" and fills *counts, or says what is wrong (and leaves *counts empty).
[[nodiscard]] std::string DecodeDepthPixels(const depth_image_t& msg,
                                            std::vector<uint16_t>* counts);

/// Sets chunk->encoding, data and data_size from `probabilities` (num_blocks x block_edge^3 cells,
/// block by block, x fastest): ENCODING_FLOAT32, ENCODING_ZLIB_FLOAT32, or ENCODING_U16_ZLIB
/// (round(P x 65535), lossy), compressed at zlib_level (0-9). @throws std::invalid_argument on an
/// unknown encoding, std::runtime_error if zlib fails.
void EncodeMapChunkCells(const std::vector<float>& probabilities, int8_t encoding, int zlib_level,
                         map3d_chunk_t* chunk);

/// The cells of a snapshot chunk (num_blocks x block_edge^3 probabilities). Checks the block
/// edge (1-64), the counts, that every block's cells lie in a map's index range (-2^23, 2^23)
/// per axis (so a consumer may compute them in int), the encoding and the payload's size. Returns
/// "" and fills *probabilities, or says what is wrong.
[[nodiscard]] std::string DecodeMapChunkCells(const map3d_chunk_t& chunk,
                                              std::vector<float>* probabilities);

/// The changed cells of a map delta, whatever its encoding.
struct MapDeltaCells {
  std::vector<std::array<int32_t, 3>> cells;  ///< cell indices
  std::vector<float> probabilities;           ///< posterior of each cell
};

/// Sets delta->encoding, num_cells, cells, probabilities, num_packed_cells, data and data_size to
/// hold `cells` (same sizes): ENCODING_CELLS (the arrays) or ENCODING_ZLIB_CELLS (coordinates
/// as zigzag varints of their differences, probabilities byte plane by byte plane, deflated at
/// zlib_level 0-9; exact: the same floats come back; see docs/design.md §7.6). @throws
/// std::invalid_argument on an unknown encoding or mismatched sizes, std::runtime_error if zlib
/// fails.
void EncodeMapDeltaCells(const MapDeltaCells& cells, int8_t encoding, int zlib_level,
                         map3d_delta_t* delta);

/// The cells of a delta, either encoding. Checks the counts against the arrays and the payload
/// (which must inflate to exactly num_packed_cells entries, no byte left over), the resolution
/// (positive, finite), the probabilities ([0, 1], not NaN) and every index (within (-2^23, 2^23)
/// per axis). Returns "" and fills *out, or says what is wrong.
[[nodiscard]] std::string DecodeMapDelta(const map3d_delta_t& delta, MapDeltaCells* out);

/// What is wrong with a delta ("" if nothing): DecodeMapDelta's checks.
[[nodiscard]] std::string CheckMapDelta(const map3d_delta_t& delta);

/// The deltas a map copy keeps while a paced snapshot's chunks arrive (docs/design.md §3.3): from
/// the snapshot's first chunk on, each delta of the same mapper (epoch) that follows the snapshot,
/// or the last delta kept (prev_seq), is kept, to be applied once the snapshot is whole. Used by
/// the explorer's MapReplica and the viewer's VoxelStream.
class SnapshotDeltaBuffer {
 public:
  /// The first chunk of a snapshot of mapper `epoch` at `map_seq`: forgets what was kept.
  void Begin(int64_t epoch, int64_t map_seq);
  /// Keeps `delta` if it follows the snapshot or the last kept delta; returns whether it did.
  bool Keep(const map3d_delta_t& delta);
  /// The kept deltas in the order they came; none are kept after.
  [[nodiscard]] std::vector<map3d_delta_t> Take();

 private:
  int64_t epoch_{0};
  int64_t tail_seq_{-1};
  std::vector<map3d_delta_t> deltas_;
};

}  // namespace kestrel

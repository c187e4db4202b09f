#pragma once
/// @file
/// Map files: Kestrel's own checkpoint format, and exports for existing tools.
///
/// Kestrel map file, version 2 (little-endian, as written by an x86/ARM host):
///   "KSTRLMAP" (8 bytes), u32 version = 2, u32 byte-order mark 0x01020304,
///   u8 grid kind (0 dense, 1 growing), u8 updater (0 exact, 1 log-odds), u16 reserved = 0,
///   f64 resolution_m, f64 origin_m[3], f64 max_m[3] (dense: half a cell inside the last cell,
///   so ceil((max - min)/alpha) restores the cell counts; growing: = origin),
///   f64 max_range_m, f64 updater parameters[5] (exact: p_init, p_min, 0, 0, 0; log-odds: p_hit,
///   p_miss, p_clamp_min, p_clamp_max, p_unknown),
///   u32 run id length, run id bytes ("" in a map that is not a checkpoint, docs/design.md §3.5),
///   u32 stream count, then per stream: u32 name length, name bytes, u32 epoch count, then per
///   publisher epoch in the order first applied: i64 epoch, i64 last applied sequence
///   (docs/design.md §3.4),
///   dense: u64 cell count, f32 values (x fastest); growing: u64 block count, then per block
///   i32 origin cell[3] and 512 f32 values,
///   u32 CRC-32 (zlib crc32) of every byte before it.
/// Version 1 (before publisher epochs) has no run id, and per stream only an i64 last applied
/// sequence; it still loads, with run id "" and each stream's sequence under epoch 0
/// (kUnknownEpoch), which no publisher stamps, so it matches no message.
/// Loading reads the whole file, checks size, checksum, magic, version and every length before
/// building anything, and returns a new map or throws MapFileError: a corrupt or truncated file
/// is refused and never half-loaded. Saving writes `path.tmp` and renames it over `path`, so a
/// crash while saving leaves the previous file intact.

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "mapping/occupancy_map.h"

namespace kestrel {

/// A refused map file: what() names the file and the reason.
class MapFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The last applied sequence number of one publisher epoch on an input stream.
struct EpochSequence {
  int64_t epoch{0};     ///< the publisher's epoch (common/identity.h)
  int64_t last_seq{0};  ///< the highest seq applied (or skipped for good) from that epoch
  bool operator==(const EpochSequence& o) const {
    return epoch == o.epoch && last_seq == o.last_seq;
  }
};

/// Per input stream (channel, e.g. "DEPTH_XTION"), every publisher epoch applied, in the order
/// each was first applied (the last one is the current publisher), with its last applied
/// sequence number (docs/design.md §3.4).
using StreamSequences = std::map<std::string, std::vector<EpochSequence>>;

/// The epoch of the sequences read from a version 1 file, which no publisher stamps.
inline constexpr int64_t kUnknownEpoch = 0;

/// What a map file says about itself, read without building the map.
struct MapFileInfo {
  uint32_t version{0};        ///< file format version (1 or 2)
  bool dense{true};           ///< dense (true) or growing grid
  std::string run_id;         ///< the run that wrote it, "" if none (docs/design.md §3.5)
  StreamSequences sequences;  ///< the stream positions
};

/// A loaded map with its stream positions.
template <class Map>
struct LoadedMap {
  std::unique_ptr<Map> map;   ///< the map, entropy recomputed
  std::string run_id;         ///< the run that wrote it, "" if none
  StreamSequences sequences;  ///< last applied sequence per stream and publisher epoch
};

/// Current file format version (written); version 1 is still read.
inline constexpr uint32_t kMapFileVersion = 2;

/// Saves a dense map (exact or log-odds) with its stream positions and the run id of a
/// checkpoint ("" for a map that is not one). @throws MapFileError if the file cannot be
/// written or a name does not fit the format.
void SaveMap(const std::string& path, const DenseOccupancyMap& map,
             const StreamSequences& sequences, const std::string& run_id = "");
/// Saves a growing map with its stream positions and run id.
/// @throws MapFileError if the file cannot be written or a name does not fit the format.
void SaveMap(const std::string& path, const GrowingOccupancyMap& map,
             const StreamSequences& sequences, const std::string& run_id = "");

/// The bytes SaveMap writes (checksum included): the pure core of SaveMap.
/// @throws MapFileError if a name does not fit the format.
[[nodiscard]] std::string EncodeMap(const DenseOccupancyMap& map, const StreamSequences& sequences,
                                    const std::string& run_id = "");
/// Same for a growing map.
[[nodiscard]] std::string EncodeMap(const GrowingOccupancyMap& map,
                                    const StreamSequences& sequences,
                                    const std::string& run_id = "");

/// The pure cores of the loaders below: the same checks on a whole file's bytes, with `name`
/// standing in for the path in errors. Every load goes through them (the file versions only read
/// the bytes), so they are what the fuzzer exercises (docs/design.md §7.7).
/// @throws MapFileError as the loaders.
[[nodiscard]] MapFileInfo DecodeMapFileInfo(const std::string& bytes, const std::string& name);
[[nodiscard]] LoadedMap<DenseOccupancyMap> DecodeDenseMap(const std::string& bytes,
                                                          const std::string& name);
[[nodiscard]] LoadedMap<GrowingOccupancyMap> DecodeGrowingMap(const std::string& bytes,
                                                              const std::string& name);

/// Reads and checks a map file (size, checksum, magic, version, header) and returns what it
/// says about itself, without building the map.
/// @throws MapFileError (missing, truncated, corrupt, unknown version).
MapFileInfo ReadMapFileInfo(const std::string& path);

/// Loads a dense map saved by SaveMap.
/// @throws MapFileError (missing, truncated, corrupt, wrong version or grid kind).
LoadedMap<DenseOccupancyMap> LoadDenseMap(const std::string& path);
/// Loads a growing map saved by SaveMap.
/// @throws MapFileError (missing, truncated, corrupt, wrong version or grid kind).
LoadedMap<GrowingOccupancyMap> LoadGrowingMap(const std::string& path);

/// Exports to OctoMap (liboctomap): ".bt" (binary, max-likelihood occupied/free) or ".ot" (full
/// log-odds), chosen by the extension. OctoMap's lattice has its origin at 0, Kestrel's at the
/// lower map limit, so each observed cell (value != the untouched value) is written to the
/// OctoMap voxel of the same resolution that contains its centre, with log-odds
/// ln(P/(1-P)); the tree's clamping thresholds are widened to the map's probability range.
/// @throws MapFileError on another extension or a write failure.
void ExportOctoMap(const std::string& path, const DenseOccupancyMap& map);
/// Same for a growing map.
void ExportOctoMap(const std::string& path, const GrowingOccupancyMap& map);

/// Writes an ASCII PLY point cloud of the centres (m, W) of the occupied cells (P > 0.5), with a
/// float property "probability". Returns the number of points.
/// @throws MapFileError if the file cannot be written.
size_t ExportOccupiedPly(const std::string& path, const DenseOccupancyMap& map);
/// Same for a growing map.
size_t ExportOccupiedPly(const std::string& path, const GrowingOccupancyMap& map);

}  // namespace kestrel

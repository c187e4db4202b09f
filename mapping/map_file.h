#pragma once
/// @file
/// Map files: Kestrel's own checkpoint format, and exports for existing tools.
///
/// Kestrel map file, version 1 (little-endian, as written by an x86/ARM host):
///   "KSTRLMAP" (8 bytes), u32 version = 1, u32 byte-order mark 0x01020304,
///   u8 grid kind (0 dense, 1 growing), u8 updater (0 exact, 1 log-odds), u16 reserved = 0,
///   f64 resolution_m, f64 origin_m[3], f64 max_m[3] (dense: half a cell inside the last cell,
///   so ceil((max - min)/alpha) restores the cell counts; growing: = origin),
///   f64 max_range_m, f64 updater parameters[5] (exact: p_init, p_min, 0, 0, 0; log-odds: p_hit,
///   p_miss, p_clamp_min, p_clamp_max, p_unknown),
///   u32 stream count, then per stream: u32 name length, name bytes, i64 last applied sequence,
///   dense: u64 cell count, f32 values (x fastest); growing: u64 block count, then per block
///   i32 origin cell[3] and 512 f32 values,
///   u32 CRC-32 (zlib crc32) of every byte before it.
/// Loading reads the whole file, checks size, checksum, magic, version and every length before
/// building anything, and returns a new map or throws MapFileError: a corrupt or truncated file
/// is refused and never half-loaded. Saving writes `path.tmp` and renames it over `path`, so a
/// crash while saving leaves the previous file intact.

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>

#include "mapping/occupancy_map.h"

namespace kestrel {

/// A refused map file: what() names the file and the reason.
class MapFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Last applied sequence number of every named input stream (e.g. "DEPTH_XTION" -> 1234).
using StreamSequences = std::map<std::string, int64_t>;

/// A loaded map with its stream positions.
template <class Map>
struct LoadedMap {
  std::unique_ptr<Map> map;   ///< the map, entropy recomputed
  StreamSequences sequences;  ///< last applied sequence per stream
};

/// Current file format version.
inline constexpr uint32_t kMapFileVersion = 1;

/// Saves a dense map (exact or log-odds) with its stream positions.
/// @throws MapFileError if the file cannot be written.
void SaveMap(const std::string& path, const DenseOccupancyMap& map,
             const StreamSequences& sequences);
/// Saves a growing map with its stream positions.
/// @throws MapFileError if the file cannot be written.
void SaveMap(const std::string& path, const GrowingOccupancyMap& map,
             const StreamSequences& sequences);

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

// libFuzzer target: Kestrel map files, versions 1 and 2, maps saved with --save and the mapper's
// checkpoints alike (mapping/map_file.h), through the loaders' pure cores (docs/design.md §7.7).
// Input: one flag byte, then the file. Flag bit 0 set: the file is given without its CRC-32 and
// the target appends the right one, so that the fuzzer reaches past the checksum. Properties,
// beyond no crash and no sanitizer report: a refused file throws MapFileError and nothing else;
// a loaded map, saved, loads again and saves to the same bytes, with the same run id, stream
// table and header as the first load.
#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include "mapping/map_file.h"

namespace {

void Require(bool condition) {
  if (!condition) std::abort();
}

template <class Map>
void CheckResave(const kestrel::LoadedMap<Map>& first,
                 kestrel::LoadedMap<Map> (*decode)(const std::string&, const std::string&)) {
  const std::string saved = kestrel::EncodeMap(*first.map, first.sequences, first.run_id);
  kestrel::LoadedMap<Map> second;
  try {
    second = decode(saved, "saved.kmap");
  } catch (const kestrel::MapFileError&) {
    std::abort();  // what SaveMap writes must load
  }
  Require(second.run_id == first.run_id && second.sequences == first.sequences);
  Require(kestrel::EncodeMap(*second.map, second.sequences, second.run_id) == saved);
  const kestrel::MapFileInfo info = kestrel::DecodeMapFileInfo(saved, "saved.kmap");
  Require(info.version == kestrel::kMapFileVersion && info.run_id == first.run_id &&
          info.sequences == first.sequences);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  if ((data[0] & 1) != 0) {
    const uint32_t crc = static_cast<uint32_t>(
        crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size())));
    bytes.append(reinterpret_cast<const char*>(&crc), sizeof(crc));
  }
  bool info_ok = false;
  kestrel::MapFileInfo info;
  try {
    info = kestrel::DecodeMapFileInfo(bytes, "fuzz.kmap");
    info_ok = true;
    Require(info.version == 1 || info.version == 2);
    Require(info.version == 2 || info.run_id.empty());
  } catch (const kestrel::MapFileError&) {
  }
  try {
    const auto dense = kestrel::DecodeDenseMap(bytes, "fuzz.kmap");
    Require(info_ok && info.dense && dense.run_id == info.run_id &&
            dense.sequences == info.sequences);
    CheckResave(dense, &kestrel::DecodeDenseMap);
  } catch (const kestrel::MapFileError&) {
  }
  try {
    const auto growing = kestrel::DecodeGrowingMap(bytes, "fuzz.kmap");
    Require(info_ok && !info.dense && growing.run_id == info.run_id &&
            growing.sequences == info.sequences);
    CheckResave(growing, &kestrel::DecodeGrowingMap);
  } catch (const kestrel::MapFileError&) {
  }
  return 0;
}

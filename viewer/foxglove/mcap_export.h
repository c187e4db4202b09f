#pragma once
/// @file
/// kestrel-mcap-export's work: a recorded run (an LCM log from lcm-logger or kestrel-mission
/// --log) as an MCAP file that Foxglove opens, with the topics of the live endpoint
/// (foxglove_bridge.h: /map, /tf, /map2d/<name>, /trajectory, /candidates, /params/<process>),
/// JSON-encoded with
/// JSON Schemas, in zstd-compressed, indexed chunks (mcap_writer.h). Each message's log time is
/// the logger's receive time, its publish time the message's own stamp. The map's changed blocks
/// are written every map_period_s of log time, and once more at the end.

#include <cstdint>
#include <map>
#include <string>

#include "viewer/foxglove/foxglove_bridge.h"

namespace kestrel::foxglove {

struct McapExportConfig {
  std::string log_path;
  std::string out_path;
  std::string compression{"zstd"};  ///< "zstd" or "" (none)
  size_t chunk_size_bytes{4 << 20};
  double map_period_s{1.0};  ///< the map's changed blocks every this much log time, s (> 0)
  BridgeConfig bridge;
};

struct McapExportSummary {
  int64_t events{0};                         ///< log events read
  int64_t refused{0};                        ///< events the bridge refused (malformed)
  int64_t messages{0};                       ///< MCAP messages written
  std::map<std::string, int64_t> per_topic;  ///< messages per topic
  uint64_t bytes{0};                         ///< size of the MCAP file
  bool truncated{false};                     ///< the log ended inside an event
};

/// Reads the log and writes the MCAP file. @throws std::runtime_error when the log cannot be read
/// or the file cannot be written, std::invalid_argument on a bad configuration.
McapExportSummary ExportMcap(const McapExportConfig& config);

}  // namespace kestrel::foxglove

#include "viewer/foxglove/mcap_export.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/log.h"
#include "viewer/foxglove/mcap_writer.h"

namespace kestrel::foxglove {

McapExportSummary ExportMcap(const McapExportConfig& config) {
  if (!(config.map_period_s > 0)) throw std::invalid_argument("map_period_s must be above 0");
  std::error_code ec;
  const std::uintmax_t log_bytes = std::filesystem::file_size(config.log_path, ec);
  if (ec) throw std::runtime_error("cannot read the log " + config.log_path + ": " + ec.message());
  lcm::LogFile log(config.log_path, "r");
  if (!log.good()) throw std::runtime_error("cannot read the log " + config.log_path);
  std::ofstream out(config.out_path, std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("cannot write " + config.out_path);

  mcap::McapWriterOptions options;
  options.profile = "";
  options.library = "kestrel-mcap-export";
  options.compression = config.compression;
  options.chunk_size_bytes = config.chunk_size_bytes;
  mcap::McapWriter writer(out, options);
  Bridge bridge(config.bridge);
  McapExportSummary summary;
  std::map<std::string, uint16_t> schema_ids;   // by schema name
  std::map<std::string, uint16_t> channel_ids;  // by topic
  std::map<std::string, uint32_t> sequence;     // by topic
  std::map<std::string, int64_t> refused_by_channel;

  auto write = [&](const Message& m, uint64_t log_time_ns) {
    auto channel = channel_ids.find(m.topic);
    if (channel == channel_ids.end()) {
      auto schema = schema_ids.find(m.schema_name);
      if (schema == schema_ids.end()) {
        schema = schema_ids
                     .emplace(m.schema_name, writer.AddSchema(m.schema_name, "jsonschema",
                                                              SchemaOf(m.schema_name)))
                     .first;
      }
      channel =
          channel_ids.emplace(m.topic, writer.AddChannel(schema->second, m.topic, "json")).first;
    }
    writer.WriteMessage(channel->second, sequence[m.topic]++, log_time_ns,
                        m.time_ns > 0 ? m.time_ns : log_time_ns, m.json.data(), m.json.size());
    ++summary.messages;
    ++summary.per_topic[m.topic];
  };

  const auto period_ns = static_cast<uint64_t>(config.map_period_s * 1e9);
  uint64_t next_map_ns = 0;
  uint64_t last_ns = 0;
  std::vector<Message> messages;
  long end = 0;  // just after the last complete event
  while (const lcm::LogEvent* event = log.readNextEvent()) {
    end = std::ftell(log.getFilePtr());
    ++summary.events;
    const uint64_t log_time_ns = event->timestamp > 0 ? uint64_t(event->timestamp) * 1000 : 0;
    last_ns = std::max(last_ns, log_time_ns);
    messages.clear();
    std::string error;
    if (!bridge.OnLcm(event->channel, event->data, static_cast<size_t>(event->datalen), &messages,
                      &error)) {
      ++summary.refused;
      if (refused_by_channel[event->channel]++ == 0) {
        Log(LogLevel::kWarning, event->channel + ": a message not exported: " + error +
                                    " (counted; said once per channel)");
      }
    }
    for (const Message& m : messages) write(m, log_time_ns);
    if (log_time_ns >= next_map_ns) {
      next_map_ns = log_time_ns + period_ns;
      if (const auto update = bridge.TakeMapUpdate()) write(*update, log_time_ns);
    }
  }
  if (const auto update = bridge.TakeMapUpdate()) write(*update, last_ns);
  if (summary.events == 0 && log_bytes > 0) {  // nothing readable: not an LCM log
    out.close();
    std::filesystem::remove(config.out_path, ec);
    throw std::runtime_error("the log " + config.log_path + " holds no LCM event (" +
                             std::to_string(log_bytes) + " bytes): not an LCM log?");
  }
  // lcm::LogFile stops at a torn last event without saying so: compare the position with the size.
  if (end >= 0 && static_cast<std::uintmax_t>(end) < log_bytes) {
    summary.truncated = true;
    Log(LogLevel::kWarning, "the log " + config.log_path + " ends inside an event (" +
                                std::to_string(end) + " of " + std::to_string(log_bytes) +
                                " bytes read): exported the events before it");
  }
  writer.Close();
  out.close();
  if (!out) throw std::runtime_error("cannot write " + config.out_path);
  std::ifstream written(config.out_path, std::ios::binary | std::ios::ate);
  summary.bytes = static_cast<uint64_t>(written.tellg());
  return summary;
}

}  // namespace kestrel::foxglove

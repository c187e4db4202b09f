#include "viewer/foxglove/mcap_writer.h"

#include <zstd.h>

#include <algorithm>
#include <stdexcept>

namespace kestrel::mcap {
namespace {

void PutU8(std::string* out, uint8_t v) { out->push_back(static_cast<char>(v)); }
template <typename T>
void PutLE(std::string* out, T v) {
  for (size_t i = 0; i < sizeof(T); ++i) {
    out->push_back(static_cast<char>((static_cast<uint64_t>(v) >> (8 * i)) & 0xff));
  }
}
void PutString(std::string* out, const std::string& s) {
  PutLE<uint32_t>(out, static_cast<uint32_t>(s.size()));
  out->append(s);
}
/// A u32 byte length and then `body` (maps and arrays).
void PutPrefixed32(std::string* out, const std::string& body) {
  PutLE<uint32_t>(out, static_cast<uint32_t>(body.size()));
  out->append(body);
}

}  // namespace

uint32_t Crc32(const void* data, size_t size, uint32_t crc) {
  static const auto table = [] {
    std::vector<uint32_t> t(256);
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  const auto* p = static_cast<const uint8_t*>(data);
  crc = ~crc;
  for (size_t i = 0; i < size; ++i) crc = table[(crc ^ p[i]) & 0xff] ^ (crc >> 8);
  return ~crc;
}

std::string McapWriter::Record(Opcode op, const std::string& content) {
  std::string r;
  PutU8(&r, static_cast<uint8_t>(op));
  PutLE<uint64_t>(&r, content.size());
  r.append(content);
  return r;
}

McapWriter::McapWriter(std::ostream& out, McapWriterOptions options)
    : out_(out), options_(std::move(options)) {
  if (!options_.compression.empty() && options_.compression != "zstd") {
    throw std::invalid_argument("MCAP compression '" + options_.compression +
                                "': use \"\" or \"zstd\"");
  }
  Write(std::string(kMagic, sizeof(kMagic)));
  std::string header;
  PutString(&header, options_.profile);
  PutString(&header, options_.library);
  Write(Record(Opcode::kHeader, header));
}

void McapWriter::Write(const std::string& bytes) {
  out_.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out_) throw std::runtime_error("MCAP: the output stream failed");
  offset_ += bytes.size();
  // The data section's CRC: every byte from the magic up to the Data End record (as the
  // reference writers compute it).
  if (!data_ended_) data_crc_ = Crc32(bytes.data(), bytes.size(), data_crc_);
}

uint16_t McapWriter::AddSchema(const std::string& name, const std::string& encoding,
                               const std::string& data) {
  if (closed_) throw std::logic_error("MCAP: AddSchema after Close");
  const auto id = static_cast<uint16_t>(schema_records_.size() + 1);
  std::string content;
  PutLE<uint16_t>(&content, id);
  PutString(&content, name);
  PutString(&content, encoding);
  PutString(&content, data);  // bytes with a u32 length, as a string
  schema_records_.push_back(Record(Opcode::kSchema, content));
  chunk_records_ += schema_records_.back();  // before any message of it, in the data section
  return id;
}

uint16_t McapWriter::AddChannel(uint16_t schema_id, const std::string& topic,
                                const std::string& message_encoding,
                                const std::map<std::string, std::string>& metadata) {
  if (closed_) throw std::logic_error("MCAP: AddChannel after Close");
  if (schema_id > schema_records_.size()) {
    throw std::invalid_argument("MCAP: channel " + topic + " names unknown schema " +
                                std::to_string(schema_id));
  }
  const auto id = static_cast<uint16_t>(channel_records_.size());
  std::string content;
  PutLE<uint16_t>(&content, id);
  PutLE<uint16_t>(&content, schema_id);
  PutString(&content, topic);
  PutString(&content, message_encoding);
  std::string map;
  for (const auto& [key, value] : metadata) {
    PutString(&map, key);
    PutString(&map, value);
  }
  PutPrefixed32(&content, map);
  channel_records_.push_back(Record(Opcode::kChannel, content));
  channel_schema_[id] = schema_id;
  chunk_records_ += channel_records_.back();
  return id;
}

void McapWriter::WriteMessage(uint16_t channel_id, uint32_t sequence, uint64_t log_time_ns,
                              uint64_t publish_time_ns, const void* data, size_t size) {
  if (closed_) throw std::logic_error("MCAP: WriteMessage after Close");
  if (channel_schema_.count(channel_id) == 0) {
    throw std::invalid_argument("MCAP: unknown channel " + std::to_string(channel_id));
  }
  std::string content;
  PutLE<uint16_t>(&content, channel_id);
  PutLE<uint32_t>(&content, sequence);
  PutLE<uint64_t>(&content, log_time_ns);
  PutLE<uint64_t>(&content, publish_time_ns);
  content.append(static_cast<const char*>(data), size);
  chunk_message_index_[channel_id].emplace_back(log_time_ns, chunk_records_.size());
  chunk_records_ += Record(Opcode::kMessage, content);
  if (!chunk_has_messages_) {
    chunk_start_time_ = chunk_end_time_ = log_time_ns;
    chunk_has_messages_ = true;
  }
  chunk_start_time_ = std::min(chunk_start_time_, log_time_ns);
  chunk_end_time_ = std::max(chunk_end_time_, log_time_ns);
  if (message_count_ == 0) start_time_ = end_time_ = log_time_ns;
  start_time_ = std::min(start_time_, log_time_ns);
  end_time_ = std::max(end_time_, log_time_ns);
  ++message_count_;
  ++channel_message_counts_[channel_id];
  if (chunk_records_.size() >= options_.chunk_size_bytes) FlushChunk();
}

void McapWriter::FlushChunk() {
  if (chunk_records_.empty()) return;
  std::string stored;
  if (options_.compression == "zstd") {
    stored.resize(ZSTD_compressBound(chunk_records_.size()));
    const size_t n = ZSTD_compress(stored.data(), stored.size(), chunk_records_.data(),
                                   chunk_records_.size(), 3);
    if (ZSTD_isError(n) != 0) {
      throw std::runtime_error(std::string("MCAP: zstd: ") + ZSTD_getErrorName(n));
    }
    stored.resize(n);
  } else {
    stored = chunk_records_;
  }
  std::string content;
  PutLE<uint64_t>(&content, chunk_start_time_);
  PutLE<uint64_t>(&content, chunk_end_time_);
  PutLE<uint64_t>(&content, chunk_records_.size());
  PutLE<uint32_t>(&content, Crc32(chunk_records_.data(), chunk_records_.size()));
  PutString(&content, options_.compression);
  PutLE<uint64_t>(&content, stored.size());
  content += stored;
  ChunkIndex index;
  index.start_time = chunk_start_time_;
  index.end_time = chunk_end_time_;
  index.chunk_offset = offset_;
  const std::string chunk = Record(Opcode::kChunk, content);
  index.chunk_length = chunk.size();
  index.compressed_size = stored.size();
  index.uncompressed_size = chunk_records_.size();
  Write(chunk);
  const uint64_t indexes_start = offset_;
  for (const auto& [channel, entries] : chunk_message_index_) {
    std::string array;
    for (const auto& [time, at] : entries) {
      PutLE<uint64_t>(&array, time);
      PutLE<uint64_t>(&array, at);
    }
    std::string record_content;
    PutLE<uint16_t>(&record_content, channel);
    PutPrefixed32(&record_content, array);
    index.message_index_offsets[channel] = offset_;
    const std::string record = Record(Opcode::kMessageIndex, record_content);
    Write(record);
  }
  index.message_index_length = offset_ - indexes_start;
  chunk_indexes_.push_back(index);
  chunk_records_.clear();
  chunk_message_index_.clear();
  chunk_has_messages_ = false;
  chunk_start_time_ = chunk_end_time_ = 0;
}

void McapWriter::Close() {
  if (closed_) return;
  FlushChunk();
  closed_ = true;
  std::string data_end;
  PutLE<uint32_t>(&data_end, data_crc_);
  data_ended_ = true;
  Write(Record(Opcode::kDataEnd, data_end));

  const uint64_t summary_start = offset_;
  std::string summary;
  struct Group {
    Opcode opcode;
    uint64_t start, length;
  };
  std::vector<Group> groups;
  auto add_group = [&](Opcode op, const std::vector<std::string>& records) {
    if (records.empty()) return;
    const uint64_t start = summary_start + summary.size();
    for (const std::string& r : records) summary += r;
    groups.push_back({op, start, summary_start + summary.size() - start});
  };
  add_group(Opcode::kSchema, schema_records_);
  add_group(Opcode::kChannel, channel_records_);
  {
    std::string stats;
    PutLE<uint64_t>(&stats, message_count_);
    PutLE<uint16_t>(&stats, static_cast<uint16_t>(schema_records_.size()));
    PutLE<uint32_t>(&stats, static_cast<uint32_t>(channel_records_.size()));
    PutLE<uint32_t>(&stats, 0);  // attachments
    PutLE<uint32_t>(&stats, 0);  // metadata
    PutLE<uint32_t>(&stats, static_cast<uint32_t>(chunk_indexes_.size()));
    PutLE<uint64_t>(&stats, start_time_);
    PutLE<uint64_t>(&stats, end_time_);
    std::string counts;
    for (const auto& [channel, count] : channel_message_counts_) {
      PutLE<uint16_t>(&counts, channel);
      PutLE<uint64_t>(&counts, count);
    }
    PutPrefixed32(&stats, counts);
    add_group(Opcode::kStatistics, {Record(Opcode::kStatistics, stats)});
  }
  std::vector<std::string> chunk_index_records;
  for (const ChunkIndex& c : chunk_indexes_) {
    std::string content;
    PutLE<uint64_t>(&content, c.start_time);
    PutLE<uint64_t>(&content, c.end_time);
    PutLE<uint64_t>(&content, c.chunk_offset);
    PutLE<uint64_t>(&content, c.chunk_length);
    std::string offsets;
    for (const auto& [channel, at] : c.message_index_offsets) {
      PutLE<uint16_t>(&offsets, channel);
      PutLE<uint64_t>(&offsets, at);
    }
    PutPrefixed32(&content, offsets);
    PutLE<uint64_t>(&content, c.message_index_length);
    PutString(&content, options_.compression);
    PutLE<uint64_t>(&content, c.compressed_size);
    PutLE<uint64_t>(&content, c.uncompressed_size);
    chunk_index_records.push_back(Record(Opcode::kChunkIndex, content));
  }
  add_group(Opcode::kChunkIndex, chunk_index_records);
  const uint64_t summary_offset_start = summary_start + summary.size();
  for (const Group& g : groups) {
    std::string content;
    PutU8(&content, static_cast<uint8_t>(g.opcode));
    PutLE<uint64_t>(&content, g.start);
    PutLE<uint64_t>(&content, g.length);
    summary += Record(Opcode::kSummaryOffset, content);
  }
  // The Footer's CRC covers the summary, the summary offsets and the Footer up to the CRC.
  std::string footer;
  PutU8(&footer, static_cast<uint8_t>(Opcode::kFooter));
  PutLE<uint64_t>(&footer, 8 + 8 + 4);
  PutLE<uint64_t>(&footer, summary_start);
  PutLE<uint64_t>(&footer, summary_offset_start);
  uint32_t crc = Crc32(summary.data(), summary.size());
  crc = Crc32(footer.data(), footer.size(), crc);
  PutLE<uint32_t>(&footer, crc);
  Write(summary);
  Write(footer);
  Write(std::string(kMagic, sizeof(kMagic)));
  out_.flush();
  if (!out_) throw std::runtime_error("MCAP: the output stream failed");
}

}  // namespace kestrel::mcap

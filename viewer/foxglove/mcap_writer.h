#pragma once
/// @file
/// An MCAP file writer (the MCAP format, https://mcap.dev/spec, version 0: the "MCAP0" magic):
/// Header, then chunks of Schema, Channel and Message records (compressed with zstd or stored),
/// each followed by its Message Index records, Data End with the data section's CRC, and a
/// summary (every Schema and Channel again, Statistics, a Chunk Index per chunk) with Summary
/// Offset records and the Footer, so that indexed readers (Foxglove, the mcap library's
/// McapIndexedReader) seek by time and streaming readers read front to back.
///
/// Pure but for the std::ostream it writes to. All integers little-endian; strings are a u32
/// length and bytes; maps and arrays a u32 byte length and their entries (spec "Serialization").

#include <cstddef>
#include <cstdint>
#include <map>
#include <ostream>
#include <string>
#include <vector>

namespace kestrel::mcap {

/// The record opcodes (spec "Records").
enum class Opcode : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

/// The 8 bytes at both ends of an MCAP file.
inline constexpr char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};

/// CRC-32 (IEEE 802.3, the one MCAP uses) of `size` bytes, continuing from `crc`.
[[nodiscard]] uint32_t Crc32(const void* data, size_t size, uint32_t crc = 0);

struct McapWriterOptions {
  std::string profile;               ///< Header.profile ("" : no well-known profile)
  std::string library{"kestrel"};    ///< Header.library
  size_t chunk_size_bytes{1 << 20};  ///< a chunk is closed once its records exceed this
  std::string compression;           ///< "" (stored) or "zstd"
};

class McapWriter {
 public:
  /// Writes the magic and the Header. @throws std::invalid_argument on an unknown compression.
  McapWriter(std::ostream& out, McapWriterOptions options);
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  /// A schema (ids from 1; 0 means "no schema"). @throws std::logic_error after Close().
  uint16_t AddSchema(const std::string& name, const std::string& encoding, const std::string& data);
  /// A channel (ids from 0). @throws std::invalid_argument on an unknown schema id (0 allowed).
  uint16_t AddChannel(uint16_t schema_id, const std::string& topic,
                      const std::string& message_encoding,
                      const std::map<std::string, std::string>& metadata = {});
  /// One message. @throws std::invalid_argument on an unknown channel, std::logic_error after
  /// Close(), std::runtime_error when the stream fails.
  void WriteMessage(uint16_t channel_id, uint32_t sequence, uint64_t log_time_ns,
                    uint64_t publish_time_ns, const void* data, size_t size);
  /// Writes the open chunk, Data End, the summary and the Footer. Idempotent.
  void Close();

  [[nodiscard]] uint64_t messages() const { return message_count_; }
  [[nodiscard]] uint32_t chunks() const { return static_cast<uint32_t>(chunk_indexes_.size()); }
  [[nodiscard]] uint64_t bytes_written() const { return offset_; }

 private:
  struct ChunkIndex {
    uint64_t start_time{0}, end_time{0}, chunk_offset{0}, chunk_length{0};
    std::map<uint16_t, uint64_t> message_index_offsets;
    uint64_t message_index_length{0}, compressed_size{0}, uncompressed_size{0};
  };
  void Write(const std::string& bytes);
  void FlushChunk();
  static std::string Record(Opcode op, const std::string& content);

  std::ostream& out_;
  McapWriterOptions options_;
  uint64_t offset_{0};
  uint32_t data_crc_{0};
  bool data_ended_{false};
  bool closed_{false};
  // Definitions, kept for the summary.
  std::vector<std::string> schema_records_;
  std::vector<std::string> channel_records_;
  std::map<uint16_t, uint16_t> channel_schema_;
  // The open chunk.
  std::string chunk_records_;
  uint64_t chunk_start_time_{0}, chunk_end_time_{0};
  bool chunk_has_messages_{false};
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_message_index_;
  // Statistics.
  uint64_t message_count_{0}, start_time_{0}, end_time_{0};
  std::map<uint16_t, uint64_t> channel_message_counts_;
  std::vector<ChunkIndex> chunk_indexes_;
};

}  // namespace kestrel::mcap

// The MCAP writer against the format's specification (https://mcap.dev/spec), read back here by a
// parser written from the spec: magic at both ends, Header, chunks whose CRC (zlib's crc32, an
// independent implementation) and sizes match their records, Message Index offsets that point at
// their messages, Data End's CRC, the summary's Schema/Channel/Statistics/Chunk Index records and
// Summary Offsets, and the Footer's offsets and CRC; for stored and zstd chunks.
#include <zlib.h>
#include <zstd.h>

#include <cstring>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "viewer/foxglove/mcap_writer.h"

namespace kestrel::mcap {
namespace {

uint32_t ZlibCrc(const std::string& bytes, size_t begin, size_t end) {
  return static_cast<uint32_t>(crc32(0L, reinterpret_cast<const Bytef*>(bytes.data() + begin),
                                     static_cast<uInt>(end - begin)));
}

/// A cursor over little-endian fields.
struct Reader {
  const std::string& b;
  size_t at;
  uint64_t U(int n) {
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; --i)
      v = (v << 8) | static_cast<uint8_t>(b.at(at + static_cast<size_t>(i)));
    at += static_cast<size_t>(n);
    return v;
  }
  std::string Bytes(size_t n) {
    std::string s = b.substr(at, n);
    at += n;
    return s;
  }
  std::string Str() { return Bytes(static_cast<size_t>(U(4))); }
};

struct Record {
  uint8_t opcode;
  size_t offset;  ///< of the opcode in its buffer
  std::string content;
};

std::vector<Record> Records(const std::string& b, size_t begin, size_t end) {
  std::vector<Record> out;
  Reader r{b, begin};
  while (r.at < end) {
    Record rec;
    rec.offset = r.at;
    rec.opcode = static_cast<uint8_t>(r.U(1));
    rec.content = r.Bytes(static_cast<size_t>(r.U(8)));
    out.push_back(rec);
  }
  EXPECT_EQ(r.at, end);
  return out;
}

std::string Write(const std::string& compression, size_t chunk_size, int messages) {
  std::ostringstream out;
  McapWriterOptions options;
  options.profile = "test";
  options.compression = compression;
  options.chunk_size_bytes = chunk_size;
  McapWriter w(out, options);
  const uint16_t s = w.AddSchema("foxglove.Grid", "jsonschema", R"({"title":"foxglove.Grid"})");
  const uint16_t a = w.AddChannel(s, "/a", "json", {{"k", "v"}});
  const uint16_t b = w.AddChannel(s, "/b", "json");
  for (int i = 0; i < messages; ++i) {
    const std::string payload = R"({"i":)" + std::to_string(i) + "}";
    w.WriteMessage(i % 3 == 0 ? b : a, static_cast<uint32_t>(i), 1000 + 10 * i, 5 + i,
                   payload.data(), payload.size());
  }
  w.Close();
  w.Close();  // idempotent
  EXPECT_EQ(w.messages(), static_cast<uint64_t>(messages));
  EXPECT_EQ(w.bytes_written(), out.str().size());
  return out.str();
}

void CheckFile(const std::string& f, const std::string& compression, int messages,
               bool expect_several_chunks) {
  ASSERT_GT(f.size(), 16u);
  EXPECT_EQ(f.substr(0, 8), std::string("\x89MCAP0\r\n", 8));
  EXPECT_EQ(f.substr(f.size() - 8), std::string("\x89MCAP0\r\n", 8));
  // Footer: the last record before the magic (opcode, length 20, three fields).
  const size_t footer_at = f.size() - 8 - (1 + 8 + 20);
  Reader footer{f, footer_at};
  ASSERT_EQ(footer.U(1), 0x02u);
  ASSERT_EQ(footer.U(8), 20u);
  const auto summary_start = static_cast<size_t>(footer.U(8));
  const auto summary_offset_start = static_cast<size_t>(footer.U(8));
  const auto summary_crc = static_cast<uint32_t>(footer.U(4));
  EXPECT_EQ(summary_crc, ZlibCrc(f, summary_start, footer_at + 1 + 8 + 16));

  // The data section: Header, chunks with their indexes, Data End.
  const std::vector<Record> data = Records(f, 8, summary_start);
  ASSERT_GE(data.size(), 3u);
  ASSERT_EQ(data.front().opcode, 0x01);
  Reader header{data.front().content, 0};
  EXPECT_EQ(header.Str(), "test");
  EXPECT_EQ(header.Str(), "kestrel");
  ASSERT_EQ(data.back().opcode, 0x0F);
  Reader data_end{data.back().content, 0};
  EXPECT_EQ(data_end.U(4), ZlibCrc(f, 0, data.back().offset));

  int seen = 0, chunks = 0;
  std::map<size_t, size_t> chunk_lengths;  // offset -> record length
  std::map<uint16_t, int> per_channel;
  std::string last_chunk_records;
  for (size_t k = 1; k + 1 < data.size(); ++k) {
    const Record& rec = data[k];
    if (rec.opcode == 0x06) {
      ++chunks;
      chunk_lengths[rec.offset] = 1 + 8 + rec.content.size();
      Reader c{rec.content, 0};
      const uint64_t start = c.U(8), end = c.U(8), uncompressed_size = c.U(8);
      const auto crc = static_cast<uint32_t>(c.U(4));
      EXPECT_EQ(c.Str(), compression);
      std::string stored = c.Bytes(static_cast<size_t>(c.U(8)));
      EXPECT_EQ(c.at, rec.content.size());
      std::string records = stored;
      if (compression == "zstd") {
        records.assign(static_cast<size_t>(uncompressed_size), '\0');
        ASSERT_EQ(ZSTD_decompress(records.data(), records.size(), stored.data(), stored.size()),
                  uncompressed_size);
      }
      ASSERT_EQ(records.size(), uncompressed_size);
      EXPECT_EQ(crc, ZlibCrc(records, 0, records.size()));
      for (const Record& inner : Records(records, 0, records.size())) {
        if (inner.opcode != 0x05) {
          EXPECT_TRUE(inner.opcode == 0x03 || inner.opcode == 0x04) << int(inner.opcode);
          continue;
        }
        Reader m{inner.content, 0};
        const auto channel = static_cast<uint16_t>(m.U(2));
        const uint64_t sequence = m.U(4), log_time = m.U(8), publish_time = m.U(8);
        EXPECT_EQ(sequence, static_cast<uint64_t>(seen));
        EXPECT_EQ(log_time, 1000u + 10u * static_cast<uint64_t>(seen));
        EXPECT_EQ(publish_time, 5u + static_cast<uint64_t>(seen));
        EXPECT_EQ(channel, seen % 3 == 0 ? 1 : 0);
        EXPECT_EQ(inner.content.substr(m.at), R"({"i":)" + std::to_string(seen) + "}");
        EXPECT_GE(log_time, start);
        EXPECT_LE(log_time, end);
        ++per_channel[channel];
        ++seen;
      }
      last_chunk_records = records;
    } else if (rec.opcode == 0x07) {  // Message Index: offsets into the chunk's records
      Reader mi{rec.content, 0};
      mi.U(2);
      const auto bytes = static_cast<size_t>(mi.U(4));
      EXPECT_EQ(bytes % 16, 0u);
      for (size_t i = 0; i < bytes / 16; ++i) {
        mi.U(8);
        const auto at = static_cast<size_t>(mi.U(8));
        ASSERT_LT(at, last_chunk_records.size());
        EXPECT_EQ(static_cast<uint8_t>(last_chunk_records[at]), 0x05);
      }
    } else {
      ADD_FAILURE() << "unexpected record " << int(rec.opcode) << " in the data section";
    }
  }
  EXPECT_EQ(seen, messages);
  if (expect_several_chunks) {
    EXPECT_GT(chunks, 1);
  }

  // The summary: groups named by the Summary Offsets.
  const std::vector<Record> summary = Records(f, summary_start, summary_offset_start);
  const std::vector<Record> offsets = Records(f, summary_offset_start, footer_at);
  std::map<uint8_t, int> count;
  for (const Record& r : summary) ++count[r.opcode];
  EXPECT_EQ(count[0x03], 1);
  EXPECT_EQ(count[0x04], 2);
  EXPECT_EQ(count[0x0B], 1);
  EXPECT_EQ(count[0x08], chunks);
  ASSERT_EQ(offsets.size(), 4u);
  for (const Record& o : offsets) {
    ASSERT_EQ(o.opcode, 0x0E);
    Reader g{o.content, 0};
    const auto group_opcode = static_cast<uint8_t>(g.U(1));
    const auto start = static_cast<size_t>(g.U(8));
    const auto length = static_cast<size_t>(g.U(8));
    for (const Record& r : Records(f, start, start + length)) EXPECT_EQ(r.opcode, group_opcode);
  }
  for (const Record& r : summary) {
    Reader c{r.content, 0};
    if (r.opcode == 0x0B) {  // Statistics
      EXPECT_EQ(c.U(8), static_cast<uint64_t>(messages));
      EXPECT_EQ(c.U(2), 1u);
      EXPECT_EQ(c.U(4), 2u);
      c.U(4);
      c.U(4);
      EXPECT_EQ(c.U(4), static_cast<uint64_t>(chunks));
      EXPECT_EQ(c.U(8), 1000u);
      EXPECT_EQ(c.U(8), 1000u + 10u * static_cast<uint64_t>(messages - 1));
      EXPECT_EQ(c.U(4), 2u * 10u);
      for (int i = 0; i < 2; ++i) {
        const auto channel = static_cast<uint16_t>(c.U(2));
        EXPECT_EQ(c.U(8), static_cast<uint64_t>(per_channel[channel]));
      }
    }
    if (r.opcode == 0x08) {  // Chunk Index: the chunk it names is a chunk of that length
      c.U(8);
      c.U(8);
      const auto chunk_offset = static_cast<size_t>(c.U(8));
      const auto chunk_length = static_cast<size_t>(c.U(8));
      ASSERT_EQ(chunk_lengths.count(chunk_offset), 1u);
      EXPECT_EQ(chunk_lengths[chunk_offset], chunk_length);
      const auto map_bytes = static_cast<size_t>(c.U(4));
      for (size_t i = 0; i < map_bytes / 10; ++i) {
        c.U(2);
        const auto index_at = static_cast<size_t>(c.U(8));
        EXPECT_EQ(static_cast<uint8_t>(f.at(index_at)), 0x07);
        EXPECT_GT(index_at, chunk_offset);
      }
      c.U(8);
      EXPECT_EQ(c.Str(), compression);
    }
    if (r.opcode == 0x04) {  // Channel
      c.U(2);
      EXPECT_EQ(c.U(2), 1u);
      const std::string topic = c.Str();
      EXPECT_TRUE(topic == "/a" || topic == "/b");
      EXPECT_EQ(c.Str(), "json");
    }
  }
}

TEST(McapWriter, StoredChunksFollowTheSpec) { CheckFile(Write("", 64, 40), "", 40, true); }

TEST(McapWriter, ZstdChunksFollowTheSpec) { CheckFile(Write("zstd", 200, 60), "zstd", 60, true); }

TEST(McapWriter, OneChunkAndAnEmptyFile) {
  CheckFile(Write("zstd", 1 << 20, 5), "zstd", 5, false);
  std::ostringstream out;
  McapWriter w(out, McapWriterOptions{});
  w.Close();
  const std::string f = out.str();
  EXPECT_EQ(f.substr(0, 8), std::string(kMagic, 8));
  EXPECT_EQ(f.substr(f.size() - 8), std::string(kMagic, 8));
}

TEST(McapWriter, RefusesMisuse) {
  std::ostringstream out;
  EXPECT_THROW(McapWriter(out, McapWriterOptions{"", "x", 1024, "lz5"}), std::invalid_argument);
  McapWriter w(out, McapWriterOptions{});
  EXPECT_THROW((void)w.AddChannel(3, "/x", "json"), std::invalid_argument);
  EXPECT_THROW(w.WriteMessage(0, 0, 0, 0, "x", 1), std::invalid_argument);
  w.Close();
  EXPECT_THROW((void)w.AddSchema("s", "jsonschema", "{}"), std::logic_error);
  EXPECT_THROW(w.WriteMessage(0, 0, 0, 0, "x", 1), std::logic_error);
}

TEST(McapWriter, Crc32IsIeee) {
  const std::string text = "123456789";
  EXPECT_EQ(Crc32(text.data(), text.size()), 0xCBF43926U);  // the standard check value
  EXPECT_EQ(Crc32(text.data() + 4, 5, Crc32(text.data(), 4)), 0xCBF43926U);
}

}  // namespace
}  // namespace kestrel::mcap

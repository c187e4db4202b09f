// Tests of the pure SCIP 2.0 codec: golden bytes from the specification's worked examples
// (docs/protocols.md §1.3), replies built by hand, and encode/decode round trips on random values.
#include "drivers/hokuyo/scip_codec.h"

#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace kestrel::scip {
namespace {

// Worked examples of the SCIP 2.0 specification: sums of "00", "99" and a PP line.
TEST(ScipCodec, SumCharMatchesSpecificationExamples) {
  EXPECT_EQ(SumChar("00"), 'P');
  EXPECT_EQ(SumChar("99"), 'b');
  EXPECT_EQ(SumChar("DMIN:23"), '7');
}

// Worked examples: 1234 -> "CB" (2 chars), 5432 -> "1Dh" (3 chars), 16000000 -> "m2@0" (4).
TEST(ScipCodec, EncodesAndDecodesSpecificationExamples) {
  EXPECT_EQ(EncodeValue(1234, 2), "CB");
  EXPECT_EQ(EncodeValue(5432, 3), "1Dh");
  EXPECT_EQ(EncodeValue(16000000, 4), "m2@0");
  EXPECT_EQ(DecodeValue("CB"), 1234u);
  EXPECT_EQ(DecodeValue("1Dh"), 5432u);
  EXPECT_EQ(DecodeValue("m2@0"), 16000000u);
}

// Values that do not fit, wrong lengths and chars outside '0'..'o' are rejected.
TEST(ScipCodec, RejectsOutOfRangeValuesAndChars) {
  EXPECT_THROW(static_cast<void>(EncodeValue(4096, 2)), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(EncodeValue(1, 5)), std::invalid_argument);
  EXPECT_EQ(EncodeValue(4095, 2), "oo");
  EXPECT_FALSE(DecodeValue("").has_value());
  EXPECT_FALSE(DecodeValue("00000").has_value());
  EXPECT_FALSE(DecodeValue("0p").has_value());  // 'p' = 0x70 is past the 6-bit range
  EXPECT_FALSE(DecodeValue("/0").has_value());  // '/' = 0x2F is below it
  EXPECT_FALSE(DecodeValues("0000", 3).has_value());
}

// Property: every value that fits round-trips through 1..4 chars (seeded generator).
TEST(ScipCodec, RandomValuesRoundTrip) {
  std::mt19937 rng(7);
  for (int chars = 1; chars <= 4; ++chars) {
    std::uniform_int_distribution<uint32_t> dist(0, (1u << (6 * chars)) - 1);
    for (int i = 0; i < 2000; ++i) {
      const uint32_t v = dist(rng);
      const std::string text = EncodeValue(v, chars);
      ASSERT_EQ(text.size(), static_cast<size_t>(chars));
      ASSERT_EQ(DecodeValue(text), v) << text;
    }
  }
}

TEST(ScipCodec, EncodesCommandsWithOptionalTag) {
  EXPECT_EQ(EncodeCommand("VV"), "VV\n");
  EXPECT_EQ(EncodeCommand("MD0044072501000", "abc"), "MD0044072501000;abc\n");
  EXPECT_THROW(static_cast<void>(EncodeCommand("VV", "12345678901234567")), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(EncodeCommand("VV", "a;b")), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(EncodeCommand("V\nV")), std::invalid_argument);
}

TEST(ScipCodec, FormatsAndParsesMeasureCommands) {
  MeasureRequest md;
  md.command = "MD";
  md.start_step = 44;
  md.end_step = 725;
  md.cluster_count = 1;
  md.scan_interval = 0;
  md.num_scans = 0;
  EXPECT_EQ(FormatMeasureCommand(md), "MD0044072501000");
  MeasureRequest gd = md;
  gd.command = "GD";
  EXPECT_EQ(FormatMeasureCommand(gd), "GD0044072501");
  const auto parsed = ParseMeasureCommand("ME0000108001199;tag");
  ASSERT_TRUE(parsed.has_value());
  EXPECT_EQ(parsed->command, "ME");
  EXPECT_EQ(parsed->end_step, 1080);
  EXPECT_EQ(parsed->scan_interval, 1);
  EXPECT_EQ(parsed->num_scans, 99);
  EXPECT_FALSE(ParseMeasureCommand("MD00440725010").has_value());
  EXPECT_FALSE(ParseMeasureCommand("XX0044072501000").has_value());
  md.end_step = 10;
  EXPECT_THROW(static_cast<void>(FormatMeasureCommand(md)), std::invalid_argument);
}

// A PP reply written out by hand: "DMIN:23;7" (';' not summed) and "00P" status.
TEST(ScipCodec, ParsesHandBuiltParameterReply) {
  const std::string block = "PP\n00P\nDMIN:23;7\n";
  ParseError error;
  const auto reply = ParseReplyBlock(block, &error);
  ASSERT_TRUE(reply.has_value()) << ToString(error);
  EXPECT_EQ(reply->command(), "PP");
  EXPECT_EQ(reply->status, "00");
  const auto params = ParseParameters(*reply);
  EXPECT_EQ(params.at("DMIN"), "23");
  // Wrong sum char.
  EXPECT_FALSE(ParseReplyBlock("PP\n00P\nDMIN:23;8\n", &error).has_value());
  EXPECT_EQ(error, ParseError::kDataSum);
  EXPECT_FALSE(ParseReplyBlock("PP\n00Q\nDMIN:23;7\n", &error).has_value());
  EXPECT_EQ(error, ParseError::kStatusSum);
}

// An MD scan reply written out by hand: two steps of 5432 mm ("1Dh"), time stamp 16000000
// ("m2@0", sum '?'), data line "1Dh1Dh" (sum 'j'), status "99b".
TEST(ScipCodec, DecodesHandBuiltScanReply) {
  const std::string bytes = "MD0044004501001\n99b\nm2@0?\n1Dh1Dhj\n\n";
  ReplyParser parser;
  parser.Feed(bytes);
  const auto event = parser.Next();
  ASSERT_TRUE(event.has_value());
  ASSERT_TRUE(event->reply.has_value()) << ToString(event->error);
  EXPECT_EQ(event->reply->status, "99");
  const auto scan = DecodeScan(*event->reply);
  ASSERT_TRUE(scan.has_value());
  EXPECT_EQ(scan->timestamp_ms, 16000000u);
  EXPECT_EQ(scan->remaining_scans, 1);
  EXPECT_EQ(scan->ranges_mm, (std::vector<uint32_t>{5432, 5432}));
  EXPECT_FALSE(parser.Next().has_value());
  // The echo says 2 steps; one value ("1Dh", sum 'M') is a malformed scan.
  const auto short_reply = ParseReplyBlock("MD0044004501001\n99b\nm2@0?\n1DhM\n");
  ASSERT_TRUE(short_reply.has_value());
  EXPECT_FALSE(DecodeScan(*short_reply).has_value());
}

// SCIP 1.1's answer to the switch command: one status char, no sum.
TEST(ScipCodec, ParsesScip11SwitchReply) {
  const auto reply = ParseReplyBlock("SCIP2.0\n0\n");
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->command(), "SCIP2.0");
  EXPECT_EQ(reply->status, "0");
  EXPECT_TRUE(IsOkStatus(reply->status));
}

TEST(ScipCodec, SplitsTagFromEcho) {
  const auto reply = ParseReplyBlock("TM1;t42\n00P\n");
  ASSERT_TRUE(reply.has_value());
  EXPECT_EQ(reply->command(), "TM");
  EXPECT_EQ(reply->command_text(), "TM1");
  EXPECT_EQ(reply->tag(), "t42");
}

// 22 three-char values = 66 chars: the 22nd value straddles the 64-char line boundary.
TEST(ScipCodec, DecodesValueSplitAcrossLines) {
  std::vector<uint32_t> values;
  for (uint32_t i = 0; i < 22; ++i) values.push_back(1000 + 37 * i);
  const std::string block = EncodeDataBlock(values, 3);
  // Line 1: 64 chars + sum + LF; line 2: 2 chars + sum + LF; final LF.
  ASSERT_EQ(block.size(), 64u + 2u + 2u + 2u + 1u);
  EXPECT_EQ(block[65], '\n');
  EXPECT_EQ(block[66 + 3], '\n');
  const std::string reply_bytes = "GD0000002101\n00P\n" + std::string("m2@0?\n") + block;
  ReplyParser parser;
  parser.Feed(reply_bytes);
  const auto event = parser.Next();
  ASSERT_TRUE(event && event->reply);
  ASSERT_EQ(event->reply->lines.size(), 3u);
  EXPECT_EQ(event->reply->lines[1].size(), 64u);
  EXPECT_EQ(event->reply->lines[2].size(), 2u);
  const auto scan = DecodeScan(*event->reply);
  ASSERT_TRUE(scan.has_value());
  EXPECT_EQ(scan->ranges_mm, values);
}

TEST(ScipCodec, RejectsLinesLongerThan64Chars) {
  const std::string payload(65, '0');
  const std::string block = "GD0000002101\n00P\n" + payload + SumChar(payload) + "\n";
  ParseError error;
  EXPECT_FALSE(ParseReplyBlock(block, &error).has_value());
  EXPECT_EQ(error, ParseError::kLineTooLong);
}

std::string MakeScanReply(const std::vector<uint32_t>& ranges, uint32_t timestamp,
                          const std::string& command = "MD") {
  MeasureRequest r;
  r.command = command;
  r.start_step = 0;
  r.end_step = static_cast<int>(ranges.size()) - 1;
  const std::string ts = EncodeValue(timestamp, 4);
  std::string out = FormatMeasureCommand(r) + "\n99b\n" + ts + SumChar(ts) + "\n";
  std::vector<uint32_t> values;
  for (const uint32_t v : ranges) {
    values.push_back(v);
    if (HasIntensity(command)) values.push_back(v / 2);
  }
  return out + EncodeDataBlock(values, 3);
}

// Property: random scans, fed in random chunk sizes, come out whole and equal.
TEST(ScipCodec, IncrementalParserHandlesArbitraryChunks) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<uint32_t> range_dist(0, (1u << 18) - 1);
  std::uniform_int_distribution<int> size_dist(1, 200);
  std::uniform_int_distribution<size_t> chunk_dist(1, 97);
  std::vector<std::vector<uint32_t>> sent;
  std::string stream;
  for (int k = 0; k < 50; ++k) {
    std::vector<uint32_t> ranges(static_cast<size_t>(size_dist(rng)));
    for (auto& v : ranges) v = range_dist(rng);
    stream += MakeScanReply(ranges, static_cast<uint32_t>(k * 25), k % 2 ? "ME" : "MD");
    sent.push_back(ranges);
  }
  ReplyParser parser;
  std::vector<std::vector<uint32_t>> received;
  size_t pos = 0;
  while (pos < stream.size()) {
    const size_t n = std::min(chunk_dist(rng), stream.size() - pos);
    parser.Feed(std::string_view(stream).substr(pos, n));
    pos += n;
    while (auto event = parser.Next()) {
      ASSERT_TRUE(event->reply.has_value()) << ToString(event->error);
      const auto scan = DecodeScan(*event->reply);
      ASSERT_TRUE(scan.has_value());
      received.push_back(scan->ranges_mm);
    }
  }
  EXPECT_EQ(received, sent);
  EXPECT_EQ(parser.buffered_bytes(), 0u);
}

// Garbage between replies and a corrupted reply: the bad block is reported once, and the
// replies after it are parsed (resynchronisation at the next empty line).
TEST(ScipCodec, ResynchronisesAfterGarbageAndBadSums) {
  const std::vector<uint32_t> a{100, 200, 300}, b{400, 500, 600}, c{700, 800, 900};
  std::string corrupted = MakeScanReply(b, 2);
  corrupted[corrupted.size() - 5] ^= 0x01;  // flip a bit of a data char: the sum no longer matches
  const std::string stream =
      MakeScanReply(a, 1) + "\x01garbage\xff\n\n" + corrupted + "\n\n\n" + MakeScanReply(c, 3);
  ReplyParser parser;
  parser.Feed(stream);
  std::vector<std::vector<uint32_t>> good;
  std::vector<ParseError> errors;
  while (auto event = parser.Next()) {
    if (event->reply) {
      good.push_back(DecodeScan(*event->reply)->ranges_mm);
    } else {
      errors.push_back(event->error);
      EXPECT_GT(event->discarded_bytes, 0u);
    }
  }
  EXPECT_EQ(good, (std::vector<std::vector<uint32_t>>{a, c}));
  EXPECT_EQ(errors, (std::vector<ParseError>{ParseError::kBadEcho, ParseError::kDataSum}));
}

TEST(ScipCodec, DiscardsOverlongGarbage) {
  ReplyParser parser(1000);
  parser.Feed(std::string(1500, 'x'));
  const auto event = parser.Next();
  ASSERT_TRUE(event.has_value());
  EXPECT_EQ(event->error, ParseError::kOverflow);
  EXPECT_EQ(event->discarded_bytes, 1500u);
  parser.Feed("QT\n00P\n\n");
  const auto next = parser.Next();
  ASSERT_TRUE(next && next->reply);
  EXPECT_EQ(next->reply->command(), "QT");
}

TEST(ScipCodec, DescribesErrorStatuses) {
  EXPECT_TRUE(IsOkStatus("00"));
  EXPECT_TRUE(IsOkStatus("99"));
  EXPECT_FALSE(IsOkStatus("0E"));
  EXPECT_EQ(DescribeStatus("XX", "0E"), "0E: bad or unknown command");
  EXPECT_EQ(DescribeStatus("GD", "10"), "10: laser is off");
  EXPECT_EQ(DescribeStatus("MD", "55"), "55: hardware fault");
  EXPECT_EQ(DescribeStatus("BM", "02"), "02: laser already on");
}

}  // namespace
}  // namespace kestrel::scip

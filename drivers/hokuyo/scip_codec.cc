#include "drivers/hokuyo/scip_codec.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "common/check.h"

namespace kestrel::scip {
namespace {

bool IsValueChar(char c) { return c >= 0x30 && c < 0x30 + 64; }
bool IsUpper(char c) { return c >= 'A' && c <= 'Z'; }
bool IsDigits(std::string_view text) {
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
  }
  return !text.empty();
}
int ParseDigits(std::string_view text) {
  int value = 0;
  for (const char c : text) value = value * 10 + (c - '0');
  return value;
}
bool IsParameterCommand(std::string_view command) {
  return command == "PP" || command == "VV" || command == "II";
}
// Longest line of any reply (parameter lines of PP/VV/II are free text, but short).
constexpr size_t kMaxAnyLineChars = 255;

}  // namespace

char SumChar(std::string_view line) {
  unsigned sum = 0;
  for (const char c : line) sum += static_cast<unsigned char>(c);
  return static_cast<char>((sum & 0x3Fu) + 0x30u);
}

std::string EncodeValue(uint32_t value, int num_chars) {
  KESTREL_THROW_UNLESS(num_chars >= 1 && num_chars <= 4, "num_chars = " << num_chars);
  KESTREL_THROW_UNLESS(num_chars == 4 || value < (1u << (6 * num_chars)),
                       "value " << value << " does not fit in " << num_chars << " chars");
  std::string out(static_cast<size_t>(num_chars), '0');
  for (int i = num_chars - 1; i >= 0; --i) {
    out[static_cast<size_t>(i)] = static_cast<char>(0x30 + (value & 0x3Fu));
    value >>= 6;
  }
  return out;
}

std::optional<uint32_t> DecodeValue(std::string_view chars) {
  if (chars.empty() || chars.size() > 4) return std::nullopt;
  uint32_t value = 0;
  for (const char c : chars) {
    if (!IsValueChar(c)) return std::nullopt;
    value = (value << 6) | static_cast<uint32_t>(c - 0x30);
  }
  return value;
}

std::optional<std::vector<uint32_t>> DecodeValues(std::string_view block, int chars_per_value) {
  if (chars_per_value < 1 || chars_per_value > 4) return std::nullopt;
  const size_t n = static_cast<size_t>(chars_per_value);
  if (block.size() % n != 0) return std::nullopt;
  std::vector<uint32_t> values;
  values.reserve(block.size() / n);
  for (size_t i = 0; i < block.size(); i += n) {
    const std::optional<uint32_t> v = DecodeValue(block.substr(i, n));
    if (!v) return std::nullopt;
    values.push_back(*v);
  }
  return values;
}

std::string EncodeDataLines(std::string_view payload) {
  std::string out;
  for (size_t i = 0; i < payload.size(); i += kMaxDataLineChars) {
    const std::string_view line = payload.substr(i, kMaxDataLineChars);
    out.append(line);
    out.push_back(SumChar(line));
    out.push_back('\n');
  }
  return out;
}

std::string EncodeDataBlock(const std::vector<uint32_t>& values, int chars_per_value) {
  std::string payload;
  payload.reserve(values.size() * static_cast<size_t>(chars_per_value));
  for (const uint32_t v : values) payload += EncodeValue(v, chars_per_value);
  return EncodeDataLines(payload) + "\n";
}

std::string EncodeCommand(std::string_view command, std::string_view tag) {
  const auto clean = [](std::string_view s) {
    return s.find_first_of(";\r\n") == std::string_view::npos;
  };
  KESTREL_THROW_UNLESS(!command.empty() && clean(command), "bad SCIP command '" << command << "'");
  KESTREL_THROW_UNLESS(tag.size() <= static_cast<size_t>(kMaxTagChars) && clean(tag),
                       "bad SCIP tag '" << tag << "' (at most 16 chars, no ';' CR LF)");
  std::string out(command);
  if (!tag.empty()) {
    out.push_back(';');
    out.append(tag);
  }
  out.push_back('\n');
  return out;
}

std::string FormatMeasureCommand(const MeasureRequest& r) {
  const bool streaming = r.command.size() == 2 && r.command[0] == 'M';
  const bool single = r.command.size() == 2 && r.command[0] == 'G';
  KESTREL_THROW_UNLESS((streaming || single) && CharsPerRange(r.command) > 0,
                       "command = " << r.command);
  KESTREL_THROW_UNLESS(r.start_step >= 0 && r.start_step <= r.end_step && r.end_step <= 9999,
                       "steps " << r.start_step << ".." << r.end_step);
  KESTREL_THROW_UNLESS(r.cluster_count >= 0 && r.cluster_count <= 99,
                       "cluster_count = " << r.cluster_count);
  char text[32];
  if (streaming) {
    KESTREL_THROW_UNLESS(r.scan_interval >= 0 && r.scan_interval <= 9,
                         "scan_interval = " << r.scan_interval);
    KESTREL_THROW_UNLESS(r.num_scans >= 0 && r.num_scans <= 99, "num_scans = " << r.num_scans);
    std::snprintf(text, sizeof(text), "%s%04d%04d%02d%01d%02d", r.command.c_str(), r.start_step,
                  r.end_step, r.cluster_count, r.scan_interval, r.num_scans);
  } else {
    std::snprintf(text, sizeof(text), "%s%04d%04d%02d", r.command.c_str(), r.start_step, r.end_step,
                  r.cluster_count);
  }
  return text;
}

std::optional<MeasureRequest> ParseMeasureCommand(std::string_view text) {
  const size_t semicolon = text.find(';');
  if (semicolon != std::string_view::npos) text = text.substr(0, semicolon);
  if (text.size() < 2) return std::nullopt;
  MeasureRequest r;
  r.command = std::string(text.substr(0, 2));
  if (CharsPerRange(r.command) == 0) return std::nullopt;
  const bool streaming = r.command[0] == 'M';
  const std::string_view params = text.substr(2);
  if (params.size() != (streaming ? 13u : 10u) || !IsDigits(params)) return std::nullopt;
  r.start_step = ParseDigits(params.substr(0, 4));
  r.end_step = ParseDigits(params.substr(4, 4));
  r.cluster_count = ParseDigits(params.substr(8, 2));
  if (streaming) {
    r.scan_interval = ParseDigits(params.substr(10, 1));
    r.num_scans = ParseDigits(params.substr(11, 2));
  }
  if (r.end_step < r.start_step) return std::nullopt;
  return r;
}

int CharsPerRange(std::string_view command) {
  if (command == "MS" || command == "GS") return 2;
  if (command == "MD" || command == "GD" || command == "ME" || command == "GE") return 3;
  return 0;
}

bool HasIntensity(std::string_view command) { return command == "ME" || command == "GE"; }

std::string_view Reply::command_text() const {
  const std::string_view e(echo);
  return e.substr(0, e.find(';'));
}

std::string_view Reply::tag() const {
  const std::string_view e(echo);
  const size_t semicolon = e.find(';');
  return semicolon == std::string_view::npos ? std::string_view() : e.substr(semicolon + 1);
}

std::string_view Reply::command() const {
  const std::string_view text = command_text();
  if (text.substr(0, 4) == "SCIP") return text;
  return text.substr(0, 2);
}

const char* ToString(ParseError error) {
  switch (error) {
    case ParseError::kNone:
      return "none";
    case ParseError::kEmptyEcho:
      return "empty echo";
    case ParseError::kBadEcho:
      return "bad echo";
    case ParseError::kBadStatusLine:
      return "bad status line";
    case ParseError::kStatusSum:
      return "status sum";
    case ParseError::kDataSum:
      return "data sum";
    case ParseError::kLineTooLong:
      return "line too long";
    case ParseError::kOverflow:
      return "overflow";
  }
  return "unknown";
}

std::optional<Reply> ParseReplyBlock(std::string_view block, ParseError* error) {
  const auto fail = [error](ParseError e) -> std::optional<Reply> {
    if (error != nullptr) *error = e;
    return std::nullopt;
  };
  if (error != nullptr) *error = ParseError::kNone;
  // Split into lines (the block ends with LF; a missing final LF is tolerated).
  std::vector<std::string_view> lines;
  size_t pos = 0;
  while (pos < block.size()) {
    size_t lf = block.find('\n', pos);
    if (lf == std::string_view::npos) lf = block.size();
    lines.push_back(block.substr(pos, lf - pos));
    pos = lf + 1;
  }
  if (lines.empty() || lines[0].empty()) return fail(ParseError::kEmptyEcho);
  const std::string_view echo = lines[0];
  if (echo.size() < 2 || !IsUpper(echo[0]) || !IsUpper(echo[1]) || echo.size() > kMaxAnyLineChars) {
    return fail(ParseError::kBadEcho);
  }
  for (const char c : echo) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) {
      return fail(ParseError::kBadEcho);
    }
  }
  Reply reply;
  reply.echo = std::string(echo);
  if (lines.size() < 2) return fail(ParseError::kBadStatusLine);
  const std::string_view status = lines[1];
  if (status.size() == 1) {
    reply.status = std::string(status);  // SCIP 1.1: one char, no sum
  } else if (status.size() == 3) {
    // Some firmware answers "SCIP2.0" in SCIP 2.0 mode with "0E" + sum; all carry the sum.
    if (SumChar(status.substr(0, 2)) != status[2]) return fail(ParseError::kStatusSum);
    reply.status = std::string(status.substr(0, 2));
  } else {
    return fail(ParseError::kBadStatusLine);
  }
  const bool parameters = IsParameterCommand(reply.command());
  for (size_t i = 2; i < lines.size(); ++i) {
    const std::string_view line = lines[i];
    if (line.size() < 2) return fail(ParseError::kDataSum);  // payload + sum, at least 1 + 1
    const std::string_view payload = line.substr(0, line.size() - 1);
    const char sum = line.back();
    if (parameters) {
      if (line.size() > kMaxAnyLineChars) return fail(ParseError::kLineTooLong);
      // "KEY:value;S": ';' not summed (SCIP 2.0); early firmware summed it. Accept both.
      if (payload.back() == ';' && SumChar(payload.substr(0, payload.size() - 1)) == sum) {
        reply.lines.emplace_back(payload.substr(0, payload.size() - 1));
      } else if (SumChar(payload) == sum) {
        reply.lines.emplace_back(payload.back() == ';' ? payload.substr(0, payload.size() - 1)
                                                       : payload);
      } else {
        return fail(ParseError::kDataSum);
      }
    } else {
      if (payload.size() > static_cast<size_t>(kMaxDataLineChars)) {
        return fail(ParseError::kLineTooLong);
      }
      if (SumChar(payload) != sum) return fail(ParseError::kDataSum);
      reply.lines.emplace_back(payload);
    }
  }
  return reply;
}

void ReplyParser::Feed(std::string_view bytes) {
  // Compact once the consumed prefix dominates, so the buffer does not grow without bound.
  if (start_ > 0 && start_ >= buffer_.size() / 2) {
    buffer_.erase(0, start_);
    start_ = 0;
  }
  buffer_.append(bytes);
}

std::optional<ParseEvent> ReplyParser::Next() {
  // Stray LFs between replies are not replies.
  while (start_ < buffer_.size() && buffer_[start_] == '\n') ++start_;
  if (start_ >= buffer_.size()) return std::nullopt;
  const size_t end = buffer_.find("\n\n", start_);
  if (end == std::string::npos) {
    if (buffer_.size() - start_ > max_buffer_bytes_) {
      ParseEvent event;
      event.error = ParseError::kOverflow;
      event.discarded_bytes = buffer_.size() - start_;
      Reset();
      return event;
    }
    return std::nullopt;
  }
  const std::string_view block(buffer_.data() + start_, end + 1 - start_);
  ParseEvent event;
  event.reply = ParseReplyBlock(block, &event.error);
  if (!event.reply) event.discarded_bytes = end + 2 - start_;
  start_ = end + 2;
  return event;
}

void ReplyParser::Reset() {
  buffer_.clear();
  start_ = 0;
}

std::map<std::string, std::string> ParseParameters(const Reply& reply) {
  std::map<std::string, std::string> out;
  for (const std::string& line : reply.lines) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    out[line.substr(0, colon)] = line.substr(colon + 1);
  }
  return out;
}

std::optional<uint32_t> DecodeTimestamp(const Reply& reply) {
  if (reply.lines.empty() || reply.lines[0].size() != 4) return std::nullopt;
  return DecodeValue(reply.lines[0]);
}

std::optional<ScanData> DecodeScan(const Reply& reply) {
  const std::optional<MeasureRequest> request = ParseMeasureCommand(reply.command_text());
  if (!request) return std::nullopt;
  ScanData scan;
  const std::optional<uint32_t> timestamp = DecodeTimestamp(reply);
  if (!timestamp) return std::nullopt;
  scan.timestamp_ms = *timestamp;
  scan.remaining_scans = request->num_scans;
  std::string block;
  for (size_t i = 1; i < reply.lines.size(); ++i) block += reply.lines[i];
  const int cluster = std::max(1, request->cluster_count);
  const size_t count =
      static_cast<size_t>((request->end_step - request->start_step + cluster) / cluster);
  const int chars = CharsPerRange(request->command);
  const bool intensity = HasIntensity(request->command);
  const size_t per_step = static_cast<size_t>(chars) * (intensity ? 2u : 1u);
  if (block.size() != count * per_step) return std::nullopt;
  const std::optional<std::vector<uint32_t>> values = DecodeValues(block, chars);
  if (!values) return std::nullopt;
  if (intensity) {
    scan.ranges_mm.reserve(count);
    scan.intensities.reserve(count);
    for (size_t i = 0; i < count; ++i) {
      scan.ranges_mm.push_back((*values)[2 * i]);
      scan.intensities.push_back((*values)[2 * i + 1]);
    }
  } else {
    scan.ranges_mm = *values;
  }
  return scan;
}

bool IsOkStatus(std::string_view status) {
  return status == "00" || status == "99" || status == "0";
}

std::string DescribeStatus(std::string_view command, std::string_view status) {
  std::string meaning;
  if (status == "00") {
    meaning = "ok";
  } else if (status == "99") {
    meaning = "ok, data follows";
  } else if (status == "0C" || status == "0D" || status == "0E" || status == "0L") {
    meaning = "bad or unknown command";
  } else if (status.size() == 2 && status[0] == '0' && status[1] >= '1' && status[1] <= '9') {
    meaning = (command == "BM" && status == "02") ? "laser already on"
                                                  : "parameter error for " + std::string(command);
  } else if (status == "10") {
    meaning = "laser is off";
  } else if (status.size() == 2 && status >= "50" && status <= "97") {
    meaning = "hardware fault";
  } else if (status.size() == 1) {
    meaning = status == "0" ? "ok (SCIP 1.1)" : "SCIP 1.1 error";
  } else {
    meaning = "unknown status";
  }
  return std::string(status) + ": " + meaning;
}

}  // namespace kestrel::scip

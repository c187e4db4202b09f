#pragma once
/// @file
/// A pure SCIP 2.0 codec (Hokuyo URG / UTM laser range finders): no I/O, no clock.
///
/// Framing (docs/protocols.md §1.2): the host sends a command line "XXparams[;tag]\n"; the
/// sensor replies with the echo of that line, a status line (2 status chars + 1 sum char; SCIP 1.1
/// replies carry one status char and no sum), data lines each followed by a sum char, and an
/// empty line, so every reply ends "\n\n". The sum char of a line is (sum of its bytes & 0x3F) +
/// 0x30. Values are groups of 6 bits, most significant first, each + 0x30 (2, 3 or 4 chars).
/// Parameter lines of PP/VV/II are "KEY:value;S" where the ';' is not part of the sum.
/// Data blocks (MD/GD/ME...) are cut into lines of at most 64 chars; a value may straddle two
/// lines, so data lines are concatenated before decoding.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kestrel::scip {

/// Longest data line payload (without sum char), chars.
inline constexpr int kMaxDataLineChars = 64;
/// Longest tag the protocol accepts, chars.
inline constexpr int kMaxTagChars = 16;
/// The 24-bit time stamp counter wraps at this many milliseconds (about 4.66 h).
inline constexpr int64_t kTimestampModulus = int64_t{1} << 24;

/// The SCIP sum char of `line` (bytes summed, low 6 bits kept, + 0x30). "00" -> 'P'.
[[nodiscard]] char SumChar(std::string_view line);

/// Encodes `value` into `num_chars` (1..4) chars of 6 bits each, most significant first.
/// @throws std::invalid_argument if num_chars is outside 1..4 or value needs more bits.
[[nodiscard]] std::string EncodeValue(uint32_t value, int num_chars);
/// Decodes 1..4 chars; nullopt if the length is wrong or a char is outside '0'..'o'.
[[nodiscard]] std::optional<uint32_t> DecodeValue(std::string_view chars);
/// Decodes a concatenated data block into values of `chars_per_value` chars; nullopt if the
/// length is not a multiple or a char is invalid.
[[nodiscard]] std::optional<std::vector<uint32_t>> DecodeValues(std::string_view block,
                                                                int chars_per_value);
/// Encodes values and cuts them into data lines of at most 64 chars, each followed by its sum
/// char and LF, then the terminating LF (the sensor side of a data block).
[[nodiscard]] std::string EncodeDataBlock(const std::vector<uint32_t>& values, int chars_per_value);
/// Encodes `payload` (already value chars) as 64-char lines + sum + LF, without the final LF.
[[nodiscard]] std::string EncodeDataLines(std::string_view payload);

/// A command line: "command" (e.g. "MD0044072501000", "SCIP2.0"), optional tag, then LF.
/// @throws std::invalid_argument if the tag is longer than 16 chars or holds ';', CR or LF, or
/// if the command is empty or holds ';', CR or LF.
[[nodiscard]] std::string EncodeCommand(std::string_view command, std::string_view tag = "");

/// Parameters of a measurement command (MD/MS/ME streaming, GD/GS/GE single scan).
struct MeasureRequest {
  std::string command{"MD"};  ///< "MD", "MS", "ME", "GD", "GS" or "GE"
  int start_step{0};          ///< first step, 0..9999
  int end_step{0};            ///< last step, start_step..9999
  int cluster_count{1};       ///< steps merged per value, 0..99 (0 and 1 both mean 1)
  int scan_interval{0};       ///< scans skipped between two sent (M* only), 0..9
  int num_scans{0};           ///< scans to send, 0 = unlimited (M* only), 0..99
};
/// "MD0044072501000" style text (no tag, no LF). @throws std::invalid_argument on a bad field.
[[nodiscard]] std::string FormatMeasureCommand(const MeasureRequest& request);
/// Parses the echo of a measurement command (tag stripped first); nullopt if malformed.
[[nodiscard]] std::optional<MeasureRequest> ParseMeasureCommand(std::string_view command_text);
/// Chars per range value: 2 for MS/GS, 3 for MD/GD/ME/GE.
[[nodiscard]] int CharsPerRange(std::string_view command);
/// True for ME/GE (range and intensity, 3 chars each).
[[nodiscard]] bool HasIntensity(std::string_view command);

/// One complete reply, validated (echo present, status line well formed, every sum right).
struct Reply {
  std::string echo;                ///< echoed command line without LF, tag included
  std::string status;              ///< "00", "99", ... (SCIP 1.1 replies: one char, e.g. "0")
  std::vector<std::string> lines;  ///< data lines with the sum char (and ';') removed

  /// The echo without its ";tag".
  [[nodiscard]] std::string_view command_text() const;
  /// The tag ("" if none).
  [[nodiscard]] std::string_view tag() const;
  /// The two command letters ("SCIP2.0" for the switch command).
  [[nodiscard]] std::string_view command() const;
};

/// Why a block was rejected.
enum class ParseError {
  kNone,
  kEmptyEcho,      ///< the block starts with an empty line
  kBadEcho,        ///< the echo does not start with two upper-case letters
  kBadStatusLine,  ///< status line missing or of the wrong length
  kStatusSum,      ///< status sum char wrong
  kDataSum,        ///< a data line's sum char wrong
  kLineTooLong,    ///< a data line longer than 64 chars + sum (or a parameter line > 255)
  kOverflow,       ///< no reply end after too many bytes (garbage); bytes discarded
};
/// "data sum", "bad echo", ...
[[nodiscard]] const char* ToString(ParseError error);

/// Parses one block: the lines of a reply without the terminating empty line, each ending LF
/// (so `block` ends with exactly one LF). Parameter replies (PP/VV/II) accept the sum with or
/// without the ';' (firmware differs); other replies need the plain sum.
/// @returns the reply, or the error in *error (if non-null) and nullopt.
[[nodiscard]] std::optional<Reply> ParseReplyBlock(std::string_view block,
                                                   ParseError* error = nullptr);

/// Result of the incremental parser: a reply, or an error with the offending bytes' count.
struct ParseEvent {
  std::optional<Reply> reply;           ///< set when a valid reply was parsed
  ParseError error{ParseError::kNone};  ///< set when bytes were rejected
  size_t discarded_bytes{0};            ///< bytes dropped with the error
};

/// Incremental parser: takes arbitrary byte chunks and yields replies as they complete. A
/// rejected block (bad sum, garbage) is reported once and skipped; parsing resumes at the next
/// empty line (the reply boundary), so a stream resynchronises after garbage. Stray LFs between
/// replies are ignored. More than max_buffer_bytes without a reply end is discarded (kOverflow).
class ReplyParser {
 public:
  explicit ReplyParser(size_t max_buffer_bytes = 65536) : max_buffer_bytes_(max_buffer_bytes) {}
  /// Appends received bytes.
  void Feed(std::string_view bytes);
  /// The next reply or error; nullopt when more bytes are needed.
  [[nodiscard]] std::optional<ParseEvent> Next();
  /// Drops everything buffered.
  void Reset();
  [[nodiscard]] size_t buffered_bytes() const { return buffer_.size() - start_; }

 private:
  std::string buffer_;
  size_t start_{0};
  size_t max_buffer_bytes_;
};

/// The "KEY:value" lines of a PP/VV/II reply as a map (lines without ':' are skipped).
[[nodiscard]] std::map<std::string, std::string> ParseParameters(const Reply& reply);

/// A decoded scan of an MD/MS/ME/GD/GS/GE reply.
struct ScanData {
  uint32_t timestamp_ms{0};           ///< sensor's 24-bit millisecond clock
  int remaining_scans{0};             ///< M* replies: scans still to come (0 when unlimited)
  std::vector<uint32_t> ranges_mm;    ///< one per (cluster of) step(s), mm or error code
  std::vector<uint32_t> intensities;  ///< ME/GE only
};
/// Decodes the data of a scan reply (status "99" for M*, "00" for G*): timestamp line then the
/// concatenated data lines. nullopt if malformed (wrong count for the echoed steps, bad chars).
[[nodiscard]] std::optional<ScanData> DecodeScan(const Reply& reply);
/// Decodes a TM1 reply's time stamp; nullopt if malformed.
[[nodiscard]] std::optional<uint32_t> DecodeTimestamp(const Reply& reply);

/// True for "00" and "99" (and SCIP 1.1 "0"); anything else is an error status.
[[nodiscard]] bool IsOkStatus(std::string_view status);
/// A human-readable meaning of `status` for `command` (e.g. "0E: unknown command").
[[nodiscard]] std::string DescribeStatus(std::string_view command, std::string_view status);

}  // namespace kestrel::scip

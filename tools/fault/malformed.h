#pragma once
/// @file
/// Malformed LCM messages made on purpose, for kestrel-fault's burst (docs/design.md §7.11): pure
/// functions of a channel's sample message, a count and a seed. Every message made is one the
/// guarded decoder (common/lcm_decode.h) refuses for the sample's type, so every subscriber of
/// the channel must count it as malformed and drop it.

#include <cstdint>
#include <string>
#include <vector>

namespace kestrel {

/// The kinds of malformed message, made in this order, round and round.
enum class MalformedKind {
  kGarbage,         ///< random bytes (8 to 256 of them)
  kTruncated,       ///< the sample cut short (0 to size - 1 bytes kept)
  kBadFingerprint,  ///< the sample with random bits of its type fingerprint flipped
  kHugeLength,      ///< the sample with an array or string length field set far past its end
};

/// "garbage", "truncated", "bad_fingerprint", "huge_length".
[[nodiscard]] const char* MalformedKindName(MalformedKind kind);

struct MalformedMessage {
  MalformedKind kind{MalformedKind::kGarbage};
  std::vector<uint8_t> bytes;
};

/// The Kestrel or bot-procman type whose fingerprint opens `bytes` ("pose_t", "info2_t", ...), or
/// "" when none does (or fewer than 8 bytes).
[[nodiscard]] std::string KnownTypeOf(const std::vector<uint8_t>& bytes);
/// The fingerprint of a type KnownTypeOf names (0 for another name).
[[nodiscard]] int64_t FingerprintOf(const std::string& type_name);

/// `count` malformed messages for `channel`, cycling through the kinds. `sample` is a message
/// seen on the channel (empty if none: garbage only). A kind the sample cannot give is replaced
/// by garbage: kTruncated, kBadFingerprint need a sample of 9 bytes or more, kHugeLength a
/// sample of a known type (KnownTypeOf) holding a length field of 4 or 8 bytes (the first met is
/// set to 2^31 - 1 or 2^63 - 1). The same channel, sample, count and seed give the same bytes.
[[nodiscard]] std::vector<MalformedMessage> MakeMalformedBurst(const std::string& channel,
                                                               const std::vector<uint8_t>& sample,
                                                               int count, uint64_t seed);

}  // namespace kestrel

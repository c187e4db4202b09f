#pragma once
/// @file
/// FNV-1a, 64 bits: a small, stable hash of bytes (the same on every machine and build, unlike
/// std::hash). For identities and bit-for-bit comparisons, not for security.

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace kestrel {

/// FNV-1a's 64-bit offset basis: the hash of no bytes.
inline constexpr uint64_t kFnv1aOffset = 14695981039346656037ull;

/// Continues the hash `h` over `size` bytes at `data` (start with kFnv1aOffset).
inline uint64_t Fnv1a(const void* data, size_t size, uint64_t h = kFnv1aOffset) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    h ^= bytes[i];
    h *= 1099511628211ull;
  }
  return h;
}

/// Continues the hash `h` over the characters of `text`.
inline uint64_t Fnv1a(std::string_view text, uint64_t h = kFnv1aOffset) {
  return Fnv1a(text.data(), text.size(), h);
}

}  // namespace kestrel

// libFuzzer target for the VN-100 stream parser (tests/tools/run_fuzzer.sh builds it with ASan
// and UBSan). The input is cut into chunks (sizes from its own bytes) and fed to a Vn100Parser,
// then fed again whole to a second one; the invariants below must hold (no crash, no sanitizer
// report): both find the same messages (chunking changes nothing), every frame found passes its
// CRC when encoded again, and every ASCII line found is a VectorNav line.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "drivers/imu/vn100.h"

namespace {
void Require(bool condition) {
  if (!condition) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  kestrel::Vn100Parser chunked, whole;
  std::vector<kestrel::Vn100Message> a;
  size_t at = 0;
  while (at < input.size()) {
    const size_t n = 1 + static_cast<uint8_t>(input[at]) % 64;
    for (auto& m : chunked.Feed(input.substr(at, n))) a.push_back(m);
    at += n;
  }
  const std::vector<kestrel::Vn100Message> b = whole.Feed(input);
  Require(a.size() == b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    Require(a[i].kind == b[i].kind);
    Require(a[i].ascii == b[i].ascii);
    Require(a[i].sample.time_startup_ns == b[i].sample.time_startup_ns);
    if (a[i].kind == kestrel::Vn100Message::Kind::kAscii) {
      Require(a[i].ascii.find("\r\n") == std::string::npos);
    } else {
      const std::vector<uint8_t> again = kestrel::EncodeVn100Frame(a[i].sample);
      Require(kestrel::Vn100Crc16(again.data() + 1, again.size() - 1) == 0);
    }
  }
  Require(chunked.frames() == whole.frames());
  return 0;
}

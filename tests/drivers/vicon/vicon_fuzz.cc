// libFuzzer target for the Vicon UDP object stream parser (drivers/vicon/vicon_packet.h).
// Properties checked on every input, besides "no crash, no sanitizer report":
// - a rejected datagram gives a reason that starts with the error's name;
// - an accepted one has at most 13 objects with valid names and finite values, re-encodes to
//   exactly its own first 5 + 75 N bytes, and gives unit quaternions.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "drivers/vicon/vicon_packet.h"

namespace {

void Require(bool condition) {
  if (!condition) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (const bool padding : {true, false}) {
    kestrel::ViconParseOptions options;
    options.allow_zero_padding = padding;
    kestrel::ViconFrame frame;
    std::string reason;
    const kestrel::ViconPacketError error =
        kestrel::ParseViconDatagram(data, size, options, &frame, &reason);
    if (error != kestrel::ViconPacketError::kNone) {
      Require(reason.rfind(kestrel::ViconPacketErrorName(error), 0) == 0);
      continue;
    }
    Require(frame.objects.size() <= kestrel::kViconMaxItems);
    for (const kestrel::ViconObject& object : frame.objects) {
      Require(!object.name.empty() && object.name.size() < kestrel::kViconNameBytes);
      Require(object.translation_mm.allFinite() && object.rotation_rad.allFinite());
      for (const auto order :
           {kestrel::ViconEulerOrder::kIntrinsicXyz, kestrel::ViconEulerOrder::kExtrinsicXyz}) {
        const Eigen::Quaterniond q = kestrel::QuaternionFromViconEuler(object.rotation_rad, order);
        Require(std::abs(q.norm() - 1.0) < 1e-9);
      }
    }
    const std::vector<uint8_t> encoded = kestrel::EncodeViconDatagram(frame);
    const size_t used =
        kestrel::kViconHeaderBytes + frame.objects.size() * kestrel::kViconItemBytes;
    Require(encoded.size() == used && used <= size);
    // Bytes after a name's NUL are not carried, so compare field by field.
    Require(std::memcmp(encoded.data(), data, kestrel::kViconHeaderBytes) == 0);
    for (size_t k = 0; k < frame.objects.size(); ++k) {
      const size_t at = kestrel::kViconHeaderBytes + k * kestrel::kViconItemBytes;
      Require(std::memcmp(encoded.data() + at, data + at, 3) == 0);
      Require(std::memcmp(encoded.data() + at + 27, data + at + 27, 48) == 0);
    }
  }
  return 0;
}

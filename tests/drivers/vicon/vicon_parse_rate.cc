// Measures ParseViconDatagram throughput (not a test: timings are reported, never asserted).
// Usage: vicon_parse_rate [ITERATIONS]   prints datagrams/s for 1 and 13 objects per datagram.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "drivers/vicon/vicon_packet.h"

int main(int argc, char** argv) {
  const long iterations = argc > 1 ? std::atol(argv[1]) : 2000000;
  for (const size_t objects : {size_t{1}, kestrel::kViconMaxItems}) {
    kestrel::ViconFrame frame;
    for (size_t k = 0; k < objects; ++k) {
      frame.objects.push_back({"object_" + std::to_string(k),
                               {1000.0 + k, -2000.0, 1500.0},
                               {0.1, -0.2, 0.3 + 0.01 * static_cast<double>(k)}});
    }
    std::vector<uint8_t> bytes = kestrel::EncodeViconDatagram(frame);
    kestrel::ViconFrame parsed;
    std::string reason;
    size_t accepted = 0;
    const auto start = std::chrono::steady_clock::now();
    for (long i = 0; i < iterations; ++i) {
      bytes[0] = static_cast<uint8_t>(i);  // a new frame number each time
      accepted += kestrel::ParseViconDatagram(bytes.data(), bytes.size(), {}, &parsed, &reason) ==
                  kestrel::ViconPacketError::kNone;
    }
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf(
        "%2zu objects (%4zu bytes): %ld datagrams in %.3f s = %.3g datagrams/s, %.1f MB/s"
        " (%zu accepted)\n",
        objects, bytes.size(), iterations, s, static_cast<double>(iterations) / s,
        static_cast<double>(iterations) * static_cast<double>(bytes.size()) / s / 1e6, accepted);
  }
  return 0;
}

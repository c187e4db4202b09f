// libFuzzer target for the SCIP reply parser (tests/tools/run_fuzzer.sh builds it with ASan and
// UBSan). The input is cut into chunks (sizes from its own bytes) and fed to ReplyParser; every
// reply goes through each decoder. The same bytes are then fed to a HokuyoDriver that a canned
// start-up script has brought to streaming, so scan decoding, range mapping and the clock model
// see hostile input too. No crash, no sanitizer report, and the invariants below must hold.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "drivers/hokuyo/hokuyo_driver.h"
#include "drivers/hokuyo/scip_codec.h"

namespace {

void Require(bool condition) {
  if (!condition) std::abort();
}

std::string Param(const std::string& text) {
  return text + ";" + kestrel::scip::SumChar(text) + "\n";
}

// Brings a driver to streaming with well-formed replies (UTM-30LX, steps 0..1080).
void StartStreaming(kestrel::HokuyoDriver* driver, int64_t* now) {
  using kestrel::scip::EncodeCommand;
  driver->Start(*now);
  const auto answer = [&](const std::string& reply) {
    (void)driver->TakeOutput();
    *now += 1000;
    driver->OnBytes(reply, *now);
  };
  answer("SCIP2.0\n0Ee\n\n");
  answer("TM2\n00P\n\n");
  answer("QT\n00P\n\n");
  answer("PP\n00P\n" + Param("MODL:UTM-30LX") + Param("DMIN:23") + Param("DMAX:60000") +
         Param("ARES:1440") + Param("AMIN:0") + Param("AMAX:1080") + Param("AFRT:540") +
         Param("SCAN:2400") + "\n");
  answer("VV\n00P\n\n");
  answer("TM0\n00P\n\n");
  answer("TM1\n00P\nm2@0?\n\n");
  answer("TM2\n00P\n\n");
  answer("MD0000108001000\n00P\n\n");
  Require(driver->state() == kestrel::HokuyoDriver::State::kStreaming);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  kestrel::scip::ReplyParser parser(4096);
  size_t pos = 0;
  size_t seen = 0;
  while (pos < input.size()) {
    const size_t chunk = 1 + static_cast<unsigned char>(input[pos]) % 97;
    const std::string_view piece = input.substr(pos, chunk);
    pos += piece.size();
    parser.Feed(piece);
    while (auto event = parser.Next()) {
      Require(event->reply.has_value() != (event->error != kestrel::scip::ParseError::kNone));
      if (!event->reply) continue;
      const kestrel::scip::Reply& reply = *event->reply;
      seen += reply.echo.size();
      Require(!reply.echo.empty());
      (void)reply.command();
      (void)reply.tag();
      (void)kestrel::scip::ParseParameters(reply);
      (void)kestrel::scip::DecodeTimestamp(reply);
      (void)kestrel::scip::IsOkStatus(reply.status);
      (void)kestrel::scip::DescribeStatus(reply.command(), reply.status);
      if (const auto scan = kestrel::scip::DecodeScan(reply)) {
        Require(scan->intensities.empty() || scan->intensities.size() == scan->ranges_mm.size());
        Require(scan->timestamp_ms < (1u << 24));
      }
    }
    Require(parser.buffered_bytes() <= 4096 + 97);
  }
  (void)kestrel::scip::ParseReplyBlock(input);
  (void)kestrel::scip::ParseMeasureCommand(input);

  kestrel::HokuyoConfig config;
  config.clock_sync_samples = 1;
  config.clock_sync_spacing_s = 0.0;
  kestrel::HokuyoDriver driver(config);
  int64_t now = 1700000000000000;
  StartStreaming(&driver, &now);
  for (size_t i = 0; i < input.size(); i += 61) {
    now += 7000;
    driver.OnBytes(input.substr(i, 61), now);
    driver.OnTick(now);
    for (const kestrel::HokuyoScan& scan : driver.TakeScans()) {
      Require(scan.ranges_m.size() == 1081);
      for (const float r : scan.ranges_m) Require(!(r < 0.0f) && !(r > 60.0f));
    }
    (void)driver.TakeEvents();
    (void)driver.TakeOutput();
  }
  return 0;
}

// The vehicle drivers' hot paths (docs/protocols.md §6, §7). Release build:
//   build/bench/drivers/drivers_bench
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <atomic>
#include <string>
#include <thread>

#include "drivers/imu/vn100.h"
#include "drivers/motors/blctrl.h"
#include "drivers/motors/esc_emulator.h"
#include "drivers/motors/i2c_bus.h"

namespace {

// Frames parsed per second from a stream of back-to-back frames, fed in 4 kB reads as the node
// reads the port.
void BM_Vn100ParseFrames(benchmark::State& state) {
  std::string stream;
  for (int i = 0; i < 1000; ++i) {
    kestrel::Vn100Sample s;
    s.time_startup_ns = 1250000ULL * static_cast<uint64_t>(i);
    s.accel_mps2 = {0.01F * static_cast<float>(i % 7), 0.0F, -9.8F};
    const std::vector<uint8_t> f = kestrel::EncodeVn100Frame(s);
    stream.append(f.begin(), f.end());
  }
  kestrel::Vn100Parser parser;
  for (auto _ : state) {
    for (size_t at = 0; at < stream.size(); at += 4096) {
      benchmark::DoNotOptimize(parser.Feed(std::string_view(stream).substr(at, 4096)));
    }
  }
  state.SetItemsProcessed(state.iterations() * 1000);
}
BENCHMARK(BM_Vn100ParseFrames);

void BM_Vn100EncodeFrame(benchmark::State& state) {
  kestrel::Vn100Sample s;
  for (auto _ : state) {
    ++s.time_startup_ns;
    benchmark::DoNotOptimize(kestrel::EncodeVn100Frame(s));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Vn100EncodeFrame);

// One refresh of four rotors: thrust to set point and bytes.
void BM_BlCtrlEncodeRefresh(benchmark::State& state) {
  kestrel::EscMap map;
  double t = 1.0;
  for (auto _ : state) {
    for (int i = 0; i < 4; ++i) {
      const int s = kestrel::ThrustToBlCtrlSetPoint(map, kestrel::BlCtrlVersion::kV2, t, true);
      benchmark::DoNotOptimize(kestrel::EncodeBlCtrlSetPoint(kestrel::BlCtrlVersion::kV2, s));
    }
    t = t > 20.0 ? 1.0 : t + 0.01;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BlCtrlEncodeRefresh);

// A whole refresh (four set-point writes in one transfer) through the socket to the emulated
// ESCs and back: the time kestrel-motors' write takes in hardware-in-the-loop simulation.
void BM_SocketRefreshRoundTrip(benchmark::State& state) {
  const std::string path = "/tmp/kestrel-bench-esc-" + std::to_string(::getpid()) + ".sock";
  kestrel::EscMap map;
  kestrel::EscEmulator escs(kestrel::BlCtrlVersion::kV2, {0x29, 0x2a, 0x2b, 0x2c}, map, 0.5);
  kestrel::I2cSocketServer server(path, [&](kestrel::I2cMessage& m) { return escs.Handle(m, 0); });
  std::atomic<bool> stop{false};
  std::thread devices([&] {
    while (!stop) server.Poll(5);
  });
  {
    kestrel::SocketI2cBus bus(path, 1000);
    std::vector<kestrel::I2cMessage> write;
    for (int i = 0; i < 4; ++i) {
      write.push_back({static_cast<uint8_t>(0x29 + i), false,
                       kestrel::EncodeBlCtrlSetPoint(kestrel::BlCtrlVersion::kV2, 1000 + i)});
    }
    std::string error;
    for (auto _ : state) {
      if (!bus.Transfer(&write, &error)) state.SkipWithError(error.c_str());
    }
  }
  stop = true;
  devices.join();
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SocketRefreshRoundTrip);

}  // namespace

BENCHMARK_MAIN();

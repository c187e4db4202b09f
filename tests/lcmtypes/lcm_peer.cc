// lcm_peer: publishes or receives every Kestrel message type, for the multi-process and
// logger/player tests. Each message is a deterministic sample (sample_messages.h), so the
// receiver checks content byte for byte by re-encoding its own copy of the same sample.
//
//   lcm_peer publish URL COUNT [PERIOD_MS]   publishes COUNT samples of every type
//   lcm_peer receive URL COUNT TIMEOUT_S     exits 0 once COUNT samples of every type arrived
//                                            intact (in order, no duplicates), 1 otherwise
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "common/lcm_decode.h"
#include "tests/lcmtypes/sample_messages.h"

namespace {

using kestrel::testing::Encode;
using kestrel::testing::MakeSample;

struct Publisher {
  lcm::LCM& lcm;
  uint64_t index;
  template <typename T>
  void Visit() {
    const T msg = MakeSample<T>(index);
    lcm.publish(std::string("TEST_") + T::getTypeName(), &msg);
  }
};

struct Counts {
  std::map<std::string, int> received;
  std::map<std::string, int> bad;
};

struct Subscriber {
  kestrel::GuardedSubscriptions& subs;
  Counts& counts;
  template <typename T>
  void Visit() {
    const std::string type = T::getTypeName();
    counts.received[type] = 0;
    Counts* c = &counts;  // this visitor is a temporary: capture the counts, not `this`
    subs.Add<T>(
        "TEST_" + type,
        [c, type](const std::string&, const T& msg) {
          // Samples arrive in order 0, 1, 2...: compare with our own copy, byte for byte.
          const int k = c->received[type];
          if (Encode(msg) != Encode(MakeSample<T>(static_cast<uint64_t>(k)))) {
            std::fprintf(stderr, "lcm_peer: %s sample %d differs\n", type.c_str(), k);
            ++c->bad[type];
          }
          ++c->received[type];
        },
        [c, type](const std::string& channel, const std::string& reason) {
          std::fprintf(stderr, "lcm_peer: dropped on %s: %s\n", channel.c_str(), reason.c_str());
          ++c->bad[type];
        });
  }
};

int Usage() {
  std::fprintf(stderr,
               "usage: lcm_peer publish URL COUNT [PERIOD_MS]\n"
               "       lcm_peer receive URL COUNT TIMEOUT_S\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) return Usage();
  const std::string mode = argv[1];
  lcm::LCM lcm(argv[2]);
  if (!lcm.good()) {
    std::fprintf(stderr, "lcm_peer: cannot open LCM at %s\n", argv[2]);
    return 1;
  }
  const int count = std::atoi(argv[3]);
  if (mode == "publish") {
    const int period_ms = argc > 4 ? std::atoi(argv[4]) : 2;
    for (int k = 0; k < count; ++k) {
      kestrel::testing::ForEachMessageType(Publisher{lcm, static_cast<uint64_t>(k)});
      std::this_thread::sleep_for(std::chrono::milliseconds(period_ms));
    }
    return 0;
  }
  if (mode == "receive" && argc >= 5) {
    const double timeout_s = std::atof(argv[4]);
    Counts counts;
    kestrel::GuardedSubscriptions subs(lcm);
    kestrel::testing::ForEachMessageType(Subscriber{subs, counts});
    std::printf("ready\n");
    std::fflush(stdout);
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000));
    auto complete = [&] {
      for (const auto& [type, n] : counts.received) {
        if (n < count) return false;
      }
      return true;
    };
    while (!complete() && std::chrono::steady_clock::now() < deadline) lcm.handleTimeout(50);
    int bad_total = 0;
    for (const auto& [type, n] : counts.received) {
      const int bad = counts.bad.count(type) ? counts.bad.at(type) : 0;
      bad_total += bad;
      std::printf("%-24s received %d of %d, bad %d\n", type.c_str(), n, count, bad);
    }
    const bool ok = complete() && bad_total == 0 &&
                    static_cast<int>(counts.received.size()) == kestrel::testing::kNumMessageTypes;
    std::printf("%s\n", ok ? "PASS" : "FAIL");
    return ok ? 0 : 1;
  }
  return Usage();
}

// kestrel-fault: faults injected into a running system (docs/design.md §7.11). One today:
// `malformed`, a burst of malformed messages on every channel (tools/fault/malformed.h).
#include <chrono>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>

#include "common/command_line.h"
#include "common/node_loop.h"
#include "common/process.h"
#include "tools/fault/malformed.h"

namespace {
const char* const kUsage =
    "usage: kestrel-fault malformed [--seconds-listen S] [--count-per-channel N] [--seed S]\n"
    "                               [--channels A,B,...] [--lcm-url URL]\n"
    "  malformed: listens S seconds (default 1) to every channel (or only to --channels), then\n"
    "             publishes on each channel heard (or named) N malformed messages (default 8):\n"
    "             random garbage, a truncated copy of a message heard there, a copy with a\n"
    "             corrupted fingerprint, a copy with a huge array length, round and round "
    "(garbage\n"
    "             where no message was heard). Prints per channel how many of each kind it sent;\n"
    "             the same seed and messages heard give the same bytes. Exit 1 if no channel.\n";

// Keeps the first message heard on each channel.
struct Sampler {
  std::map<std::string, std::vector<uint8_t>> first;
  void Handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if (first.count(channel) != 0) return;
    const auto* bytes = static_cast<const uint8_t*>(rbuf->data);
    first[channel].assign(bytes, bytes + rbuf->data_size);
  }
};
}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> words;
  double seconds_listen = 1.0;
  int count = 8;
  uint64_t seed = 1;
  std::string channels_text;
  return kestrel::RunProcess(
      "kestrel-fault", argc, argv, kUsage,
      [&](CLI::App& app) {
        app.add_option("--seconds-listen", seconds_listen)->check(kestrel::cli::NonNegative());
        app.add_option("--count-per-channel", count)->check(kestrel::cli::NonNegative());
        app.add_option("--seed", seed);
        app.add_option("--channels", channels_text);
        app.add_option("words", words);
      },
      [&](const kestrel::ProcessArgs& args, kestrel::ConfigNode&) {
        if (words.size() != 1 || words[0] != "malformed") {
          std::fprintf(stderr, "%s", kUsage);
          return 2;
        }
        lcm::LCM lcm(args.lcm_url);
        if (!lcm.good()) throw std::runtime_error("cannot open LCM at '" + args.lcm_url + "'");
        std::vector<std::string> named;
        std::stringstream list(channels_text);
        for (std::string c; std::getline(list, c, ',');) {
          if (!c.empty()) named.push_back(c);
        }
        Sampler sampler;
        lcm::Subscription* sub = lcm.subscribe(".*", &Sampler::Handle, &sampler);
        const auto end = std::chrono::steady_clock::now() +
                         std::chrono::milliseconds(static_cast<int64_t>(seconds_listen * 1000));
        while (std::chrono::steady_clock::now() < end && !kestrel::NodeLoop::signal_received()) {
          lcm.handleTimeout(20);
        }
        lcm.unsubscribe(sub);
        if (const int signum = kestrel::NodeLoop::received_signal()) {
          std::fprintf(stderr,
                       "kestrel-fault: interrupted by signal %d while listening; nothing sent\n",
                       signum);
          return kestrel::NodeLoop::ExitCodeForSignal(signum);
        }
        std::vector<std::string> channels = named;
        if (channels.empty()) {
          for (const auto& entry : sampler.first) channels.push_back(entry.first);
        }
        if (channels.empty()) {
          std::fprintf(stderr, "kestrel-fault: no channel heard in %.1f s and none named\n",
                       seconds_listen);
          return 1;
        }
        for (const std::string& channel : channels) {
          const auto it = sampler.first.find(channel);
          const std::vector<uint8_t> sample =
              it == sampler.first.end() ? std::vector<uint8_t>{} : it->second;
          std::map<std::string, int> sent;
          for (const kestrel::MalformedMessage& m :
               kestrel::MakeMalformedBurst(channel, sample, count, seed)) {
            lcm.publish(channel, m.bytes.data(), static_cast<unsigned>(m.bytes.size()));
            ++sent[kestrel::MalformedKindName(m.kind)];
          }
          const std::string type = kestrel::KnownTypeOf(sample);
          std::printf("%s (%s): %d sent", channel.c_str(), type.empty() ? "?" : type.c_str(),
                      count);
          for (const auto& [kind, n] : sent) std::printf(", %s %d", kind.c_str(), n);
          std::printf("\n");
        }
        return 0;
      });
}

#include "common/heartbeat.h"

#include <unistd.h>

#include "common/identity.h"

namespace kestrel {

Heartbeat::Heartbeat(lcm::LCM& lcm, const Clock& clock, std::string process, std::string channel)
    : lcm_(lcm),
      clock_(clock),
      process_(std::move(process)),
      channel_(std::move(channel)),
      start_utime_(clock.NowUtime()),
      epoch_(NewPublisherEpoch()) {
  char name[256] = {};
  if (gethostname(name, sizeof(name) - 1) == 0) host_ = name;
}

void Heartbeat::SetDropValues(const DropCounter& drops, const std::vector<std::string>& always) {
  auto name = [](std::string kind) {
    for (char& c : kind) c = c == ' ' ? '_' : c;
    return "dropped." + kind;
  };
  for (const std::string& kind : always) {
    values_[name(kind)] = static_cast<double>(drops.count(kind));
  }
  for (const auto& [kind, count] : drops.counts()) {
    values_[name(kind)] = static_cast<double>(count);
  }
}

void Heartbeat::Publish() {
  heartbeat_t msg;
  msg.utime = clock_.NowUtime();
  msg.seq = seq_++;
  msg.epoch = epoch_;
  msg.process = process_;
  msg.host = host_;
  msg.pid = static_cast<int32_t>(getpid());
  msg.state = state_;
  msg.uptime_s = UtimeToSeconds(msg.utime - start_utime_);
  msg.last_error = last_error_;
  for (const auto& [name, value] : values_) {
    named_value_t v;
    v.name = name;
    v.value = value;
    msg.values.push_back(v);
  }
  msg.num_values = static_cast<int32_t>(msg.values.size());
  lcm_.publish(channel_, &msg);
}

}  // namespace kestrel

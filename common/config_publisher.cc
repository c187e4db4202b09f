#include "common/config_publisher.h"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>

#include "common/identity.h"
#include "common/log.h"

namespace kestrel {

std::string ParamsChannelFor(const std::string& heartbeat_channel) {
  const std::string word = "HEARTBEAT_";
  // HEARTBEAT_<PROCESS>, or a vehicle's <PREFIX>HEARTBEAT_<PROCESS> (docs/design.md §7.10).
  const size_t at = heartbeat_channel.find(word);
  if (at != std::string::npos) {
    return "PARAMS_" + heartbeat_channel.substr(0, at) + heartbeat_channel.substr(at + word.size());
  }
  return "PARAMS_" + heartbeat_channel;
}

params_t MakeParamsMessage(const std::string& process, const ProcessArgs& args,
                           const ConfigNode& config) {
  params_t msg;
  msg.utime = 0;
  msg.seq = 0;
  msg.epoch = 0;
  msg.process = process;
  char name[256] = {};
  if (gethostname(name, sizeof(name) - 1) == 0) msg.host = name;
  msg.pid = static_cast<int32_t>(getpid());
  const char* run_id = std::getenv(kRunIdEnvironmentVariable);
  msg.run_id = run_id != nullptr ? run_id : "";
  msg.config_file = args.config_path;
  msg.args = args.command_line;
  msg.num_args = static_cast<int32_t>(msg.args.size());
  for (const ConfigValue& v : config.EffectiveValues()) {
    param_t p;
    p.file = v.file;
    p.key = v.key;
    p.value = v.value;
    p.source = static_cast<int8_t>(v.source);
    msg.params.push_back(std::move(p));
  }
  msg.num_params = static_cast<int32_t>(msg.params.size());
  return msg;
}

const char* ParamSourceName(int8_t source) {
  switch (source) {
    case param_t::SOURCE_DEFAULT:
      return "default";
    case param_t::SOURCE_FILE:
      return "file";
    case param_t::SOURCE_OVERRIDE:
      return "override";
    default:
      return "unknown";
  }
}

std::string FormatParams(const params_t& msg) {
  std::string out = msg.process + " on " + msg.host + ", pid " + std::to_string(msg.pid) +
                    (msg.run_id.empty() ? std::string() : ", run " + msg.run_id) + "\n";
  std::string command;
  for (const std::string& a : msg.args) command += (command.empty() ? "" : " ") + a;
  if (!command.empty()) out += "  command: " + command + "\n";
  std::string file;
  bool first = true;
  for (const param_t& p : msg.params) {
    if (first || p.file != file) {
      file = p.file;
      first = false;
      out += "  " + file + ":\n";
    }
    std::string line = "    " + p.key + ": " + p.value;
    if (p.source != param_t::SOURCE_FILE) {
      line.resize(std::max<size_t>(line.size() + 2, 44), ' ');
      line += std::string("# ") + ParamSourceName(p.source);
    }
    out += line + "\n";
  }
  return out;
}

ConfigPublisher::ConfigPublisher(lcm::LCM& lcm, const Clock& clock, std::string process,
                                 std::string channel, ProcessArgs args, const ConfigNode& config)
    : lcm_(lcm),
      clock_(clock),
      process_(std::move(process)),
      channel_(std::move(channel)),
      args_(std::move(args)),
      config_(config),
      epoch_(NewPublisherEpoch()),
      subscriptions_(lcm) {
  subscriptions_.Add<params_request_t>(
      kParamsRequestChannel,
      [this](const std::string&, const params_request_t& request) {
        if (request.process.empty() || request.process == process_) Publish();
      },
      [this](const std::string& request_channel, const std::string& reason) {
        if (malformed_requests_++ == 0) {
          Log(LogLevel::kWarning, request_channel + ": dropped a malformed request: " + reason);
        }
      });
  Publish();
}

void ConfigPublisher::Publish() {
  params_t msg = MakeParamsMessage(process_, args_, config_);
  msg.utime = clock_.NowUtime();
  msg.seq = seq_++;
  msg.epoch = epoch_;
  lcm_.publish(channel_, &msg);
}

}  // namespace kestrel

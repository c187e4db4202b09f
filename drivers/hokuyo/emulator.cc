#include "drivers/hokuyo/emulator.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "common/check.h"
#include "common/clock.h"
#include "drivers/hokuyo/scip_codec.h"

namespace kestrel {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr size_t kMaxSentScansKept = 100000;

std::string StatusReply(const std::string& echo, const std::string& status) {
  return echo + "\n" + status + scip::SumChar(status) + "\n\n";
}

std::string ParameterLine(const std::string& key, const std::string& value) {
  const std::string text = key + ":" + value;
  return text + ";" + scip::SumChar(text) + "\n";  // ';' not summed (SCIP 2.0)
}

std::string TimestampLine(uint32_t timestamp_ms) {
  const std::string ts = scip::EncodeValue(timestamp_ms & 0xFFFFFFu, 4);
  return ts + scip::SumChar(ts) + "\n";
}

}  // namespace

void SyntheticRoomRanges(const HokuyoModel& model, std::vector<uint32_t>* ranges_mm) {
  ranges_mm->assign(static_cast<size_t>(model.amax) + 1, 0);
  const unsigned no_object = NoObjectCode(model.name);
  for (int s = 0; s <= model.amax; ++s) {
    const double angle = model.StepAngleRad(s);
    const double c = std::cos(angle);
    const double sn = std::sin(angle);
    double d = std::numeric_limits<double>::infinity();
    if (c > 1e-12) d = std::min(d, 4.0 / c);
    if (c < -1e-12) d = std::min(d, 2.0 / -c);
    if (sn > 1e-12) d = std::min(d, 3.0 / sn);
    if (sn < -1e-12) d = std::min(d, 1.5 / -sn);
    uint32_t value = static_cast<uint32_t>(std::lround(d * 1000.0));
    if (angle >= 5.0 * kDegToRad && angle <= 15.0 * kDegToRad) value = no_object;  // doorway
    if (value >= static_cast<uint32_t>(model.dmax_mm)) value = no_object;
    if (s % 101 == 50) value = InterferenceCode(model.name);
    (*ranges_mm)[static_cast<size_t>(s)] = value;
  }
}

HokuyoEmulator::HokuyoEmulator(HokuyoEmulatorOptions options)
    : options_(std::move(options)), pty_(options_.link_path) {
  KESTREL_THROW_UNLESS(options_.model.scan_rpm > 0 && options_.model.ares > 0,
                       "bad model " << options_.model.name);
  start_utime_ = WallClock().NowUtime();
  period_us_ = SecondsToUtime(options_.model.scan_period_s());
  Plug();
  thread_ = std::thread([this] { Run(); });
}

HokuyoEmulator::~HokuyoEmulator() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  std::lock_guard<std::mutex> lock(mutex_);
  Unplug();
}

std::string HokuyoEmulator::device_path() const {
  if (!options_.link_path.empty()) return options_.link_path;
  std::lock_guard<std::mutex> lock(mutex_);
  return pty_.slave_path();
}

uint32_t HokuyoEmulator::SensorTimeMs(int64_t utime) const {
  const double elapsed_ms =
      static_cast<double>(utime - start_utime_) * (1.0 + options_.clock_drift_ppm * 1e-6) / 1000.0;
  const int64_t t = static_cast<int64_t>(std::floor(elapsed_ms)) + options_.clock_offset_ms;
  const int64_t wrapped =
      ((t % scip::kTimestampModulus) + scip::kTimestampModulus) % scip::kTimestampModulus;
  return static_cast<uint32_t>(wrapped);
}

double HokuyoEmulator::TrueOffsetUs(int64_t utime) const {
  const double sensor_us =
      static_cast<double>(utime - start_utime_) * (1.0 + options_.clock_drift_ppm * 1e-6) +
      static_cast<double>(options_.clock_offset_ms) * 1000.0;
  return static_cast<double>(utime) - sensor_us;
}

void HokuyoEmulator::CorruptNextSums(int count) {
  std::lock_guard<std::mutex> lock(mutex_);
  corrupt_sums_ += count;
}

void HokuyoEmulator::InjectGarbage(const std::string& bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  garbage_ += bytes;
}

void HokuyoEmulator::Stall(int64_t duration_ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (duration_ms < 0) {
    stalled_forever_ = true;
  } else {
    stall_until_utime_ = WallClock().NowUtime() + duration_ms * 1000;
  }
}

void HokuyoEmulator::Resume() {
  std::lock_guard<std::mutex> lock(mutex_);
  stalled_forever_ = false;
  stall_until_utime_ = 0;
}

void HokuyoEmulator::HangUp(int64_t downtime_ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  Unplug();
  replug_at_utime_ = WallClock().NowUtime() + std::max<int64_t>(0, downtime_ms) * 1000;
}

std::vector<std::string> HokuyoEmulator::received_commands() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return received_;
}

void HokuyoEmulator::ClearReceived() {
  std::lock_guard<std::mutex> lock(mutex_);
  received_.clear();
}

std::vector<EmulatedScan> HokuyoEmulator::sent_scans() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sent_scans_;
}

void HokuyoEmulator::Plug() {
  pty_.Plug();  // a no-op the first time: the pty opened with the emulator
  ResetToPowerOn();
  ++plug_count_;
}

void HokuyoEmulator::Unplug() { pty_.Unplug(); }

void HokuyoEmulator::ResetToPowerOn() {
  scip2_ = !options_.model.starts_in_scip11;
  laser_on_ = false;
  time_adjust_ = options_.start_in_time_adjust_mode;
  stream_ = Stream{};
  input_.clear();
  if (options_.start_streaming) {
    scip2_ = true;
    laser_on_ = true;
    stream_.active = true;
    stream_.command = "MD";
    stream_.start_step = options_.model.amin;
    stream_.end_step = options_.model.amax;
    stream_.next_revolution = (WallClock().NowUtime() - start_utime_) / period_us_ + 1;
  }
}

int64_t HokuyoEmulator::RevolutionStartUtime(int64_t revolution) const {
  // A multiplicative hash spreads the jitter over [0, rotation_jitter_us) without a generator.
  const uint64_t hash = static_cast<uint64_t>(revolution) * 2654435761u % 1000u;
  const int64_t jitter = static_cast<int64_t>(hash) * options_.rotation_jitter_us / 1000;
  return start_utime_ + revolution * period_us_ + jitter;
}

void HokuyoEmulator::Send(std::string reply) {
  if (pty_.master_fd() < 0) return;
  const int64_t now = WallClock().NowUtime();
  if (stalled_forever_ || now < stall_until_utime_) return;
  if (corrupt_sums_ > 0 && reply.size() >= 3) {
    // The last line's sum char sits just before the final "\n\n".
    char& sum = reply[reply.size() - 3];
    sum = static_cast<char>(0x30 + ((sum - 0x30 + 1) & 0x3F));
    --corrupt_sums_;
  }
  if (!garbage_.empty()) {
    reply.insert(reply.size() / 2, garbage_);
    garbage_.clear();
  }
  size_t done = 0;
  while (done < reply.size()) {
    const ssize_t n = ::write(pty_.master_fd(), reply.data() + done, reply.size() - done);
    if (n > 0) {
      done += static_cast<size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      break;  // EAGAIN: nobody reads and the tty buffer is full; the bytes are lost
    }
  }
}

std::string HokuyoEmulator::MakeScanReply(const std::string& echo, const std::string& status,
                                          const std::string& command, int start, int end,
                                          int cluster, int64_t revolution) {
  const HokuyoModel& m = options_.model;
  const int64_t rev_utime = RevolutionStartUtime(revolution);
  std::vector<uint32_t> all;
  if (options_.range_source) {
    options_.range_source(rev_utime, &all);
  } else {
    SyntheticRoomRanges(m, &all);
  }
  all.resize(static_cast<size_t>(m.amax) + 1, NoObjectCode(m.name));
  const int chars = scip::CharsPerRange(command);
  const bool intensity = scip::HasIntensity(command);
  const uint32_t max_value = (1u << (6 * chars)) - 1;
  std::vector<uint32_t> values;
  cluster = std::max(1, cluster);
  for (int s = start; s <= end; s += cluster) {
    uint32_t v = all[static_cast<size_t>(s)];
    for (int k = s + 1; k < std::min(s + cluster, end + 1); ++k) {
      v = std::min(v, all[static_cast<size_t>(k)]);
    }
    v = std::min(v, max_value);
    values.push_back(v);
    if (intensity) values.push_back(v < static_cast<uint32_t>(m.dmin_mm) ? 0 : 500 + v % 4000);
  }
  const int64_t first_step_utime = rev_utime + start * period_us_ / m.ares;
  const uint32_t timestamp = SensorTimeMs(first_step_utime);
  sent_scans_.push_back({timestamp, first_step_utime});
  if (sent_scans_.size() > kMaxSentScansKept) sent_scans_.erase(sent_scans_.begin());
  return echo + "\n" + status + scip::SumChar(status) + "\n" + TimestampLine(timestamp) +
         scip::EncodeDataBlock(values, chars);
}

void HokuyoEmulator::ServeStream(int64_t now_utime) {
  if (!stream_.active) return;
  const HokuyoModel& m = options_.model;
  while (stream_.active) {
    const int64_t ready_utime = RevolutionStartUtime(stream_.next_revolution) +
                                (stream_.end_step + 1) * period_us_ / m.ares;
    if (now_utime < ready_utime) return;
    const int64_t revolution = stream_.next_revolution++;
    if (now_utime - ready_utime > 2 * period_us_) continue;  // fell behind (stall): skip
    if (stream_.skip_counter > 0) {
      --stream_.skip_counter;
      continue;
    }
    stream_.skip_counter = stream_.interval;
    if (!stream_.unlimited) --stream_.remaining;
    scip::MeasureRequest r;
    r.command = stream_.command;
    r.start_step = stream_.start_step;
    r.end_step = stream_.end_step;
    r.cluster_count = stream_.cluster;
    r.scan_interval = stream_.interval;
    r.num_scans = stream_.unlimited ? 0 : stream_.remaining;
    const std::string echo = scip::FormatMeasureCommand(r) + stream_.tag;
    const bool stalled = stalled_forever_ || now_utime < stall_until_utime_;
    if (!stalled) {
      Send(MakeScanReply(echo, "99", stream_.command, stream_.start_step, stream_.end_step,
                         stream_.cluster, revolution));
    }
    if (!stream_.unlimited && stream_.remaining <= 0) stream_.active = false;
  }
}

void HokuyoEmulator::HandleLine(const std::string& line, int64_t now_utime) {
  const HokuyoModel& m = options_.model;
  const size_t semicolon = line.find(';');
  const std::string text = line.substr(0, semicolon);
  const std::string tag = semicolon == std::string::npos ? "" : line.substr(semicolon);
  if (!scip2_) {
    // SCIP 1.1: only the switch is understood here.
    if (line == "SCIP2.0") {
      scip2_ = true;
      Send("SCIP2.0\n0\n\n");
    } else {
      Send(line + "\nE\n\n");
    }
    return;
  }
  const std::string cmd = text.substr(0, std::min<size_t>(2, text.size()));
  // NOLINTNEXTLINE(bugprone-branch-clone): the same status as an unknown command, another reason
  if (text == "SCIP2.0") {
    Send(StatusReply(line, "0E"));  // already in SCIP 2.0
  } else if (text == "VV") {
    Send(line + "\n00P\n" + ParameterLine("VEND", "Hokuyo Automatic Co.,Ltd.") +
         ParameterLine("PROD", m.product) + ParameterLine("FIRM", "1.0.0(kestrel emulator)") +
         ParameterLine("PROT", "SCIP 2.0") + ParameterLine("SERI", options_.serial_number) + "\n");
  } else if (text == "PP") {
    Send(line + "\n00P\n" + ParameterLine("MODL", m.modl) +
         ParameterLine("DMIN", std::to_string(m.dmin_mm)) +
         ParameterLine("DMAX", std::to_string(m.dmax_mm)) +
         ParameterLine("ARES", std::to_string(m.ares)) +
         ParameterLine("AMIN", std::to_string(m.amin)) +
         ParameterLine("AMAX", std::to_string(m.amax)) +
         ParameterLine("AFRT", std::to_string(m.afrt)) +
         ParameterLine("SCAN", std::to_string(m.scan_rpm)) + "\n");
  } else if (text == "II") {
    Send(line + "\n00P\n" + ParameterLine("MODL", m.modl) +
         ParameterLine("LASR", laser_on_ ? "ON" : "OFF") +
         ParameterLine("SCSP", "Initial(" + std::to_string(m.scan_rpm) + "[rpm])") +
         ParameterLine("MESM", stream_.active ? "Measuring by Sensitive Mode" : "Idle") +
         ParameterLine("SBPS", "USB only") +
         ParameterLine("TIME", scip::EncodeValue(SensorTimeMs(now_utime), 4)) +
         ParameterLine("STAT", "Sensor works well.") + "\n");
  } else if (text == "BM") {
    if (time_adjust_) {
      Send(StatusReply(line, "0L"));
    } else {
      Send(StatusReply(line, laser_on_ ? "02" : "00"));
      laser_on_ = true;
    }
  } else if (text == "QT") {
    stream_.active = false;
    laser_on_ = false;
    Send(StatusReply(line, "00"));
  } else if (text == "RS") {
    stream_.active = false;
    laser_on_ = false;
    time_adjust_ = false;
    Send(StatusReply(line, "00"));
  } else if (text == "TM0" || text == "TM1" || text == "TM2") {
    if (text == "TM0") {
      Send(StatusReply(line, time_adjust_ ? "02" : "00"));
      time_adjust_ = true;
    } else if (text == "TM2") {
      Send(StatusReply(line, time_adjust_ ? "00" : "03"));
      time_adjust_ = false;
    } else if (!time_adjust_) {
      Send(StatusReply(line, "04"));
    } else {
      Send(line + "\n00P\n" + TimestampLine(SensorTimeMs(now_utime)) + "\n");
    }
  } else if (cmd == "TM") {
    Send(StatusReply(line, "01"));
  } else if (scip::CharsPerRange(cmd) > 0) {
    const std::optional<scip::MeasureRequest> r = scip::ParseMeasureCommand(text);
    if (scip::HasIntensity(cmd) && !m.has_intensity) {
      Send(StatusReply(line, "0E"));
    } else if (!r) {
      Send(StatusReply(line, "01"));
    } else if (r->end_step > m.amax) {
      Send(StatusReply(line, "04"));
    } else if (time_adjust_) {
      Send(StatusReply(line, "0L"));
    } else if (cmd[0] == 'G') {
      if (!laser_on_) {
        Send(StatusReply(line, "10"));
      } else {
        const int64_t revolution = (now_utime - start_utime_) / period_us_ - 1;
        Send(MakeScanReply(line, "00", cmd, r->start_step, r->end_step, r->cluster_count,
                           revolution));
      }
    } else {
      laser_on_ = true;
      stream_ = Stream{};
      stream_.active = true;
      stream_.command = cmd;
      stream_.tag = tag;
      stream_.start_step = r->start_step;
      stream_.end_step = r->end_step;
      stream_.cluster = std::max(1, r->cluster_count);
      stream_.interval = r->scan_interval;
      stream_.unlimited = r->num_scans == 0;
      stream_.remaining = r->num_scans;
      // The first revolution whose first requested step is still ahead.
      const int64_t first_step_offset = r->start_step * period_us_ / m.ares;
      stream_.next_revolution = (now_utime - start_utime_ - first_step_offset) / period_us_ + 1;
      Send(StatusReply(line, "00"));
    }
  } else {
    Send(StatusReply(line, "0E"));
  }
}

void HokuyoEmulator::Run() {
  while (!stop_) {
    int fd;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const int64_t now = WallClock().NowUtime();
      if (pty_.master_fd() < 0 && replug_at_utime_ >= 0 && now >= replug_at_utime_) {
        replug_at_utime_ = -1;
        Plug();
      }
      fd = pty_.master_fd();
      if (fd >= 0) ServeStream(now);
    }
    if (fd < 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      continue;
    }
    pollfd p{fd, POLLIN, 0};
    const int r = ::poll(&p, 1, 2);
    if (r <= 0 || (p.revents & POLLIN) == 0) continue;
    std::lock_guard<std::mutex> lock(mutex_);
    if (pty_.master_fd() != fd) continue;  // unplugged meanwhile
    char buf[512];
    const ssize_t n = ::read(fd, buf, sizeof(buf));
    if (n <= 0) continue;
    const int64_t now = WallClock().NowUtime();
    if (stalled_forever_ || now < stall_until_utime_) continue;  // a hung sensor hears nothing
    input_.append(buf, static_cast<size_t>(n));
    size_t eol;
    while ((eol = input_.find_first_of("\r\n")) != std::string::npos) {
      const std::string line = input_.substr(0, eol);
      input_.erase(0, eol + 1);
      if (line.empty()) continue;
      received_.push_back(line);
      HandleLine(line, now);
    }
    if (input_.size() > 256) input_.clear();  // no command is this long
  }
}

}  // namespace kestrel

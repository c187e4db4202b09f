#pragma once
/// @file
/// An emulated Hokuyo LIDAR serving SCIP 2.0 byte for byte on the master side of a
/// pseudo-terminal (openpty), so the real driver talks to it through a real tty.
///
/// Served: SCIP2.0 (URG-04LX powers up in SCIP 1.1 and answers "SCIP2.0\n0\n\n"), VV, PP, II, BM,
/// QT, RS, TM0/TM1/TM2 (a 24-bit millisecond clock that wraps, with a configurable offset and
/// drift), GD/GS/GE, MD/MS/ME streamed at the real scan rate (one scan per mirror revolution,
/// 60/SCAN s). Ranges come from a callback (the simulator) or a synthetic room.
///
/// Emulator choices where the specification is silent (documented, not verified on hardware):
/// the scan time stamp is the sensor time of the first requested step; a scan is sent when its
/// last requested step has been measured; in time-adjust mode BM and measurement commands are
/// refused with status "0L"; TM0 when already adjusting answers "02", TM2 when not adjusting
/// "03", TM1 when not adjusting "04"; SCIP 1.1 answers any other command with status "E".
///
/// Faults for tests: corrupted sums, garbage bytes inside a reply, stalls (no answers, no
/// scans) and hang-up (the pty is closed, as when the USB cable is pulled, and a new one appears
/// after a delay; a stable symlink plays the role of /dev/serial/by-id).

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/hokuyo/hokuyo_model.h"
#include "drivers/serial/pseudo_terminal.h"

namespace kestrel {

/// Fills ranges_mm (size AMAX + 1, index = step) for the revolution whose step 0 is at
/// `revolution_utime` (host clock, us). Values below DMIN are sent as error codes.
using HokuyoRangeSource =
    std::function<void(int64_t revolution_utime, std::vector<uint32_t>* ranges_mm)>;

/// A rectangular room around the sensor (sensor frame, x forward, y left): walls at x = +4 m
/// and -2 m, y = +3 m and -1.5 m; a doorway in the front wall for angles in [5, 15] deg where
/// nothing is in range (the no-object code is sent); the interference code on every step with
/// step % 101 == 50. Beyond DMAX: the no-object code.
void SyntheticRoomRanges(const HokuyoModel& model, std::vector<uint32_t>* ranges_mm);

struct HokuyoEmulatorOptions {
  HokuyoModel model{Urg04lxModel()};  ///< profile served in PP/VV/II
  int64_t clock_offset_ms{0};         ///< sensor clock value at the emulator's start (mod 2^24), ms
  double clock_drift_ppm{0.0};        ///< sensor clock runs fast by this much, 1e-6
  std::string link_path;  ///< if set, a symlink to the current slave tty (replaced on replug)
  std::string serial_number{"H1234567"};  ///< VV SERI
  bool start_in_time_adjust_mode{false};  ///< power-up state left by a previous session
  bool start_streaming{false};            ///< an MD stream left running by a previous session
  /// Revolution start jitter, us: revolution k starts at k * period + j_k, j_k in [0, this)
  /// (deterministic). A real mirror's phase is not locked to the millisecond clock; without it
  /// every first step would fall on a whole sensor millisecond.
  int64_t rotation_jitter_us{1000};
  HokuyoRangeSource range_source;  ///< empty: SyntheticRoomRanges
};

/// The emulator's record of one scan it sent: the truth for time-stamp tests.
struct EmulatedScan {
  uint32_t timestamp_ms{0};     ///< 24-bit sensor time stamp sent
  int64_t first_step_utime{0};  ///< true host time of the first requested step, us
};

class HokuyoEmulator {
 public:
  /// Creates the pty and starts serving on a thread. @throws std::runtime_error if openpty fails.
  explicit HokuyoEmulator(HokuyoEmulatorOptions options);
  ~HokuyoEmulator();
  HokuyoEmulator(const HokuyoEmulator&) = delete;
  HokuyoEmulator& operator=(const HokuyoEmulator&) = delete;

  /// The path a driver opens: link_path if set, else the current slave tty (changes on replug).
  [[nodiscard]] std::string device_path() const;
  /// The profile served.
  [[nodiscard]] const HokuyoModel& model() const { return options_.model; }

  /// Sensor clock (24-bit ms, wrapped) at host time `utime`: (utime - start) * (1 + drift) / 1000
  /// + offset, floored.
  [[nodiscard]] uint32_t SensorTimeMs(int64_t utime) const;
  /// The true offset host - sensor, us, at host time `utime` (unwrapped sensor time).
  [[nodiscard]] double TrueOffsetUs(int64_t utime) const;

  /// The next `count` replies carry a wrong sum char (last line of each reply).
  void CorruptNextSums(int count);
  /// `bytes` are inserted in the middle of the next reply (and so break it).
  void InjectGarbage(const std::string& bytes);
  /// For `duration_ms` (< 0: until Resume()) the sensor neither answers nor streams; input is
  /// discarded.
  void Stall(int64_t duration_ms);
  /// Ends a stall.
  void Resume();
  /// Closes the pty (the device is unplugged; the link is removed); after `downtime_ms` a new
  /// pty appears (link re-pointed) and the sensor is in its power-up state.
  void HangUp(int64_t downtime_ms);

  /// Command lines received (without LF), in order, since the start or ClearReceived().
  [[nodiscard]] std::vector<std::string> received_commands() const;
  /// Forgets the commands received so far.
  void ClearReceived();
  /// Scans sent, in order (bounded: the latest 100000).
  [[nodiscard]] std::vector<EmulatedScan> sent_scans() const;
  /// Number of times the pty was (re)created.
  [[nodiscard]] int plug_count() const { return plug_count_.load(); }

 private:
  struct Stream {
    bool active{false};
    std::string command;  // "MD", "MS", "ME"
    std::string tag;      // ";tag" or ""
    int start_step{0};
    int end_step{0};
    int cluster{1};
    int interval{0};
    int remaining{0};  // 0 = unlimited
    bool unlimited{true};
    int64_t next_revolution{0};  // index of the next revolution to consider
    int skip_counter{0};
  };

  void Run();
  void Plug();
  void Unplug();
  void ResetToPowerOn();
  void HandleLine(const std::string& line, int64_t now_utime);
  std::string MakeScanReply(const std::string& echo, const std::string& status,
                            const std::string& command, int start, int end, int cluster,
                            int64_t revolution);
  void Send(std::string reply);
  [[nodiscard]] int64_t RevolutionStartUtime(int64_t revolution) const;
  void ServeStream(int64_t now_utime);

  HokuyoEmulatorOptions options_;
  int64_t start_utime_{0};
  int64_t period_us_{0};

  mutable std::mutex mutex_;  // guards the fields below this line and the fds across threads
  PseudoTerminal pty_;        // the device's side; closed while unplugged
  int corrupt_sums_{0};
  std::string garbage_;
  int64_t stall_until_utime_{0};
  bool stalled_forever_{false};
  int64_t replug_at_utime_{-1};
  std::vector<std::string> received_;
  std::vector<EmulatedScan> sent_scans_;

  // Protocol state (emulator thread only).
  bool scip2_{true};
  bool laser_on_{false};
  bool time_adjust_{false};
  Stream stream_;
  std::string input_;

  std::atomic<int> plug_count_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace kestrel

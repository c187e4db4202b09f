// kestrel-controller's flight modes with the SIMULATOR's dynamics: kestrel-sim's node
// and the controller node in one process, lockstep, over memq:// LCM, the paper-sized vehicle
// (motor lag 0.02 s), the simulator's motion-capture noise and latency and IMU noise and bias.
// Upside-down start (178 deg), take-off / hold / land, e-stop, motion capture lost for 1 s and
// for longer than the land time-out. Poses reach the controller through a relay in the test that
// drops them during an outage. The figures are printed for the closing note.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "common/config.h"
#include "common/trajectory_message.h"
#include "control/controller_node.h"
#include "kestrel/command_t.hpp"
#include "sim/sim_node.h"
#include "tests/system/flight_sim_config.h"

namespace kestrel {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Sends every control step's output on to the simulator (LCM MOTOR_COMMAND) and records it.
class RecordingMotorOutput final : public MotorOutput {
 public:
  explicit RecordingMotorOutput(lcm::LCM& lcm) : lcm_output_(lcm, "MOTOR_COMMAND") {}
  void Send(int64_t utime, const FlightOutput& output) override {
    lcm_output_.Send(utime, output);
    commands.push_back({utime, output.armed, output.rotor_thrust_N});
  }
  struct Command {
    int64_t utime;
    bool armed;
    Eigen::Vector4d rotor_thrust_N;
  };
  std::vector<Command> commands;

 private:
  LcmMotorOutput lcm_output_;
};

// The simulator and the controller in lockstep (as tests/system/helix_test.cc), with a pose relay
// (POSE_SIM -> POSE_VICON, dropped during [outage_begin, outage_end)) and COMMAND arrival times.
class SimFlight {
 public:
  explicit SimFlight(AttitudeErrorForm form = AttitudeErrorForm::kLargeAngle,
                     double geofence_top_m = 3.0, bool sensor_noise = true) {
    ConfigNode sim_cfg = testing::FlightSimConfig();
    sim_cfg.ApplyOverride("channels.pose=POSE_SIM");
    if (!sensor_noise) {  // no noise, no bias, no latency: the law and the motor lag alone
      for (const char* o :
           {"mocap.position_sigma_m=0", "mocap.orientation_sigma_rad=0", "mocap.latency_s=0",
            "imu.gyro_noise_sigma_radps=0", "imu.accel_noise_sigma_mps2=0",
            "imu.gyro_bias_sigma_radps=0", "imu.accel_bias_sigma_mps2=0",
            "imu.gyro_bias_walk_radps_sqrt_s=0", "imu.accel_bias_walk_mps2_sqrt_s=0"}) {
        sim_cfg.ApplyOverride(o);
      }
    }
    sim_config_ = LoadSimConfig(sim_cfg, KESTREL_SOURCE_DIR);
    config_.flight.vehicle = sim_config_.vehicle;
    config_.flight.controller.attitude_error = form;
    // The world's geofence (WorldGeofence), its top at the test's height.
    const Geofence fence = WorldGeofence(sim_config_.world);
    config_.flight.safety.geofence_min_m = fence.min_m;
    config_.flight.safety.geofence_max_m = fence.max_m;
    config_.flight.safety.geofence_max_m.z() = geofence_top_m;
    sim_ = std::make_unique<SimNode>(lcm_, sim_config_, clock_);
    controller_ = std::make_unique<ControllerNode>(lcm_, config_, clock_, &motors_);
    period_us_ = SecondsToUtime(1.0 / config_.rate_hz);
    next_tick_us_ = clock_.NowUtime();
    lcm_.subscribe("POSE_SIM", &SimFlight::RelayPose, this);
    lcm_.subscribe("COMMAND", &SimFlight::NoteCommand, this);
  }

  // One physics step, the messages it produced, the control ticks due, their messages.
  void Step() {
    sim_->Step();
    Drain();
    while (clock_.NowUtime() >= next_tick_us_) {
      if (controller_) controller_->Tick(next_tick_us_);  // none while "killed"
      next_tick_us_ += period_us_;
    }
    Drain();
  }
  // The controller process killed (-9): no more control steps, no motor commands.
  void KillController() { controller_.reset(); }
  // A controller (re)started now with `config` (the test's wiring and geofence kept).
  void StartController(const ControllerConfig& config) {
    controller_.reset();
    config_ = config;
    controller_ = std::make_unique<ControllerNode>(lcm_, config_, clock_, &motors_);
    next_tick_us_ = clock_.NowUtime();
  }
  const ControllerNode& controller() const { return *controller_; }
  void StepFor(double duration_s) {
    const int64_t end = clock_.NowUtime() + SecondsToUtime(duration_s);
    while (clock_.NowUtime() < end) Step();
  }
  // Steps until `done` holds (checked after each step) or timeout_s passes; returns done().
  template <typename Done>
  bool StepUntil(const Done& done, double timeout_s) {
    const int64_t end = clock_.NowUtime() + SecondsToUtime(timeout_s);
    while (clock_.NowUtime() < end) {
      Step();
      if (done()) return true;
    }
    return false;
  }

  void Command(int8_t command, double height_m = 0.0) {
    command_t msg{};
    msg.utime = clock_.NowUtime();
    msg.seq = ++command_seq_;
    msg.epoch = kEpoch;
    msg.source = "flight_modes_test";
    msg.command = command;
    msg.height_m = height_m;
    lcm_.publish("COMMAND", &msg);
  }
  void Publish(const PiecewisePolynomialTrajectory& trajectory) {
    const trajectory_t msg = ToMessage(trajectory, clock_.NowUtime(), ++trajectory_seq_, kEpoch);
    lcm_.publish("TRAJECTORY", &msg);
  }
  // Poses acquired in [now + from_s, now + from_s + duration_s) are not relayed.
  void LoseMotionCapture(double from_s, double duration_s) {
    outage_begin_us_ = clock_.NowUtime() + SecondsToUtime(from_s);
    outage_end_us_ = outage_begin_us_ + SecondsToUtime(duration_s);
  }

  // Takes off by `height_m` from where the vehicle stands and waits for HOLD, then settles.
  bool TakeOffAndHold(double height_m) {
    StepFor(0.5);  // the estimator gets its first poses
    Command(command_t::COMMAND_TAKEOFF, height_m);
    const bool held = StepUntil([this] { return mode() == FlightMode::kHold; }, 15.0);
    StepFor(2.0);
    return held;
  }

  FlightMode mode() const { return controller_->flight().supervisor().mode(); }
  bool estimator_initialized() const { return controller_->flight().estimator().initialized(); }
  double now_s() const { return UtimeToSeconds(clock_.NowUtime()); }
  const QuadrotorState& truth() const { return sim_->simulator().vehicle().state(); }
  const Quadrotor& vehicle() const { return sim_->simulator().vehicle(); }
  Simulator& simulator() { return sim_->mutable_simulator(); }
  const FlightOutput& last_output() const { return controller_->last_output(); }
  const ControllerConfig& config() const { return config_; }
  const SimConfig& sim_config() const { return sim_config_; }
  const std::vector<RecordingMotorOutput::Command>& commands() const { return motors_.commands; }
  int64_t last_command_arrival_us() const { return command_arrival_us_; }
  int64_t poses_dropped() const { return poses_dropped_; }
  int64_t period_us() const { return period_us_; }
  static double TiltDeg(const QuadrotorState& s) {
    return std::acos(std::clamp(s.q_WB.toRotationMatrix()(2, 2), -1.0, 1.0)) * 180.0 / kPi;
  }

 private:
  void Drain() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }
  void RelayPose(const lcm::ReceiveBuffer* buffer, const std::string&) {
    pose_t pose;
    if (pose.decode(buffer->data, 0, buffer->data_size) < 0) return;
    if (pose.utime >= outage_begin_us_ && pose.utime < outage_end_us_) {
      ++poses_dropped_;
      return;
    }
    lcm_.publish("POSE_VICON", buffer->data, buffer->data_size);
  }
  void NoteCommand(const lcm::ReceiveBuffer*, const std::string&) {
    command_arrival_us_ = clock_.NowUtime();
  }

  lcm::LCM lcm_{"memq://"};
  SimClock clock_{1700000000000000};
  SimConfig sim_config_;
  ControllerConfig config_;
  RecordingMotorOutput motors_{lcm_};
  std::unique_ptr<SimNode> sim_;
  std::unique_ptr<ControllerNode> controller_;
  int64_t period_us_{0};
  int64_t next_tick_us_{0};
  static constexpr int64_t kEpoch = 7;  // the test's own publisher epoch
  int64_t command_seq_{0};
  int64_t trajectory_seq_{0};
  int64_t outage_begin_us_{-1};
  int64_t outage_end_us_{-1};
  int64_t poses_dropped_{0};
  int64_t command_arrival_us_{-1};
};

// A straight line at `speed_mps` along x from `start` for duration_s (one cubic segment per axis:
// constant velocity), heading 0.
PiecewisePolynomialTrajectory Line(double start_s, const Eigen::Vector3d& start, double speed_mps,
                                   double duration_s) {
  PolynomialSegment seg;
  seg.duration_s = duration_s;
  seg.coefficients[0] = {start.x(), speed_mps};
  seg.coefficients[1] = {start.y()};
  seg.coefficients[2] = {start.z()};
  seg.coefficients[3] = {0.0};
  return *PiecewisePolynomialTrajectory::Create(start_s, {seg}, nullptr);
}

// The paper's helix (docs/algorithms.md §11.8) as tests/system/helix_test.cc builds it: x_d =
// base + (0.4 t, 0.4 sin(pi t), 0.6 cos(pi t)), yaw = pi t, as 0.1 s pieces of degree-11 Taylor
// expansions.
PiecewisePolynomialTrajectory Helix(double start_s, const Eigen::Vector3d& base,
                                    double duration_s) {
  std::vector<PolynomialSegment> segments;
  const double w = kPi;
  for (double t0 = 0; t0 < duration_s - 1e-9; t0 += 0.1) {
    PolynomialSegment seg;
    seg.duration_s = 0.1;
    std::vector<double> sx, cz;
    double fact = 1.0;
    for (int k = 0; k <= 11; ++k) {
      if (k > 0) fact *= k;
      sx.push_back(0.4 * std::pow(w, k) * std::sin(w * t0 + k * kPi / 2) / fact);
      cz.push_back(0.6 * std::pow(w, k) * std::cos(w * t0 + k * kPi / 2) / fact);
    }
    sx[0] += base.y();
    cz[0] += base.z();
    seg.coefficients[0] = {base.x() + 0.4 * t0, 0.4};
    seg.coefficients[1] = sx;
    seg.coefficients[2] = cz;
    seg.coefficients[3] = {w * t0, w};
    segments.push_back(seg);
  }
  return *PiecewisePolynomialTrajectory::Create(start_s, segments, nullptr);
}

// Position RMS after the 2 s transient of the 10 s helix flown from a hover 1.6 m up.
double FlyHelix(AttitudeErrorForm form, bool sensor_noise) {
  SimFlight flight(form, 3.0, sensor_noise);
  EXPECT_TRUE(flight.TakeOffAndHold(1.6));
  const double t_start = flight.now_s() + 0.5;
  const PiecewisePolynomialTrajectory helix =
      Helix(t_start, flight.truth().p_W - Eigen::Vector3d(0, 0, 0.6), 10.0);
  flight.Publish(helix);
  double sum2 = 0.0;
  int n = 0;
  flight.StepUntil(
      [&] {
        if (flight.now_s() >= t_start + 2.0) {
          sum2 += (flight.truth().p_W - helix.Evaluate(flight.now_s()).position_m).squaredNorm();
          ++n;
        }
        return flight.now_s() >= t_start + 10.0;
      },
      12.0);
  EXPECT_GT(n, 7000);
  EXPECT_EQ(flight.vehicle().collision_count(), 0);
  const double rms_m = std::sqrt(sum2 / std::max(n, 1));
  std::printf("simulator, helix, %s e_R, %s: RMS %.1f mm\n", ToString(form),
              sensor_noise ? "with sensor noise" : "no sensor noise", rms_m * 1e3);
  return rms_m;
}

// The helix stays within these bounds with either attitude error: below 2 cm without sensor
// noise, below 5 cm with it (motor lag 0.02 s, not compensated).
TEST(FlightModes, HelixTracksWithEitherAttitudeError) {
  for (const AttitudeErrorForm form :
       {AttitudeErrorForm::kLargeAngle, AttitudeErrorForm::kCdc2010}) {
    SCOPED_TRACE(ToString(form));
    EXPECT_LT(FlyHelix(form, false), 0.02);
    EXPECT_LT(FlyHelix(form, true), 0.05);
  }
}

struct FlipFigures {
  double time_to_upright_s{-1.0};        // from release to the first tilt below 10 deg
  double altitude_lost_m{0.0};           // release height - lowest height
  double max_tilt_after_upright_deg{0};  // a second roll-over would show here
  double final_position_error_m{0.0};    // from the hold set point, at the end
  double setpoint_from_release_m{0.0};   // the hold set point from the release point
  double final_tilt_deg{180.0};
  int collisions{0};
};

// Upside down (178 deg about (1, 0.3, 0)) at rest at 40 m, held there (SetVehicleState every
// step, rotors off) until the controller has its first pose; then TAKEOFF by 0.05 m (a hold at
// the release point) and release. Flies for duration_s after the release.
FlipFigures FlyFlip(AttitudeErrorForm form, double duration_s) {
  SimFlight flight(form, 60.0);
  const double height_m = 40.0;
  QuadrotorState pinned;
  pinned.p_W = flight.truth().p_W + Eigen::Vector3d(0, 0, height_m);
  pinned.q_WB = Eigen::Quaterniond(
      Eigen::AngleAxisd(178.0 * kPi / 180.0, Eigen::Vector3d(1, 0.3, 0).normalized()));
  const auto pin_and_step = [&] {
    flight.simulator().SetVehicleState(pinned);
    flight.Step();
  };
  // Held only until the first pose reaches the estimator (a held vehicle with its rotors off
  // reads free fall on its IMU while its poses stand still: the estimate would sag).
  while (!flight.estimator_initialized()) pin_and_step();
  flight.Command(command_t::COMMAND_TAKEOFF, 0.05);
  pin_and_step();
  EXPECT_EQ(flight.mode(), FlightMode::kTakeoff);
  const Eigen::Vector3d release = pinned.p_W;
  const double release_s = flight.now_s();
  FlipFigures figures;
  double min_z = release.z();
  flight.StepUntil(
      [&] {
        const double tilt = SimFlight::TiltDeg(flight.truth());
        if (figures.time_to_upright_s < 0.0 && tilt < 10.0) {
          figures.time_to_upright_s = flight.now_s() - release_s;
        }
        if (figures.time_to_upright_s >= 0.0) {
          figures.max_tilt_after_upright_deg = std::max(figures.max_tilt_after_upright_deg, tilt);
        }
        min_z = std::min(min_z, flight.truth().p_W.z());
        return false;
      },
      duration_s);
  figures.altitude_lost_m = release.z() - min_z;
  const Eigen::Vector3d setpoint = flight.last_output().decision.setpoint.position_m;
  figures.final_position_error_m = (flight.truth().p_W - setpoint).norm();
  figures.setpoint_from_release_m = (setpoint - release).norm();
  figures.final_tilt_deg = SimFlight::TiltDeg(flight.truth());
  figures.collisions = flight.vehicle().collision_count();
  std::printf(
      "simulator, upside-down 178 deg, %s e_R: upright (tilt < 10 deg) after %.3f s, altitude "
      "lost %.2f m, largest tilt after upright %.1f deg, %.3f m from the hold point at the end\n",
      ToString(form), figures.time_to_upright_s, figures.altitude_lost_m,
      figures.max_tilt_after_upright_deg, figures.final_position_error_m);
  return figures;
}

// The default (large-angle) attitude error rights the paper-sized vehicle in the simulator within
// 1 s, losing less than 4 m, without rolling over again, and it is back within 3 cm of its hold
// point (the release point) after 8 s. (In the controller's own model: 0.56 s, 2.2 m. CDC 2010's
// error fails these bounds, see the next test.)
TEST(FlightModes, RecoversFromUpsideDownStartInTheSimulator) {
  const FlipFigures f = FlyFlip(AttitudeErrorForm::kLargeAngle, 8.0);
  RecordProperty("sim_flip_time_s", std::to_string(f.time_to_upright_s));
  RecordProperty("sim_flip_altitude_lost_m", std::to_string(f.altitude_lost_m));
  EXPECT_GT(f.time_to_upright_s, 0.0);
  EXPECT_LT(f.time_to_upright_s, 1.0);
  EXPECT_LT(f.altitude_lost_m, 4.0);
  EXPECT_LT(f.max_tilt_after_upright_deg, 60.0);
  EXPECT_LT(f.final_position_error_m, 0.03);
  EXPECT_LT(f.setpoint_from_release_m, 0.06);  // TAKEOFF by 0.05 m: a hold where it started
  EXPECT_LT(f.final_tilt_deg, 5.0);
  EXPECT_EQ(f.collisions, 0);
}

// CDC 2010's attitude error, for the record: it rights the vehicle too, but later and much lower
// (these figures violate the previous test's bounds).
TEST(FlightModes, RecoversFromUpsideDownStartWithCdc2010Error) {
  const FlipFigures f = FlyFlip(AttitudeErrorForm::kCdc2010, 16.0);
  RecordProperty("sim_flip_cdc2010_time_s", std::to_string(f.time_to_upright_s));
  RecordProperty("sim_flip_cdc2010_altitude_lost_m", std::to_string(f.altitude_lost_m));
  EXPECT_GT(f.time_to_upright_s, 1.0);
  EXPECT_GT(f.altitude_lost_m, 4.0);
  EXPECT_LT(f.final_position_error_m, 0.03);
  EXPECT_EQ(f.collisions, 0);
}

// Take-off by 1 m, a 5 s hold within 3 cm of the hold point, LAND: the vehicle ends on the floor,
// disarmed (IDLE, motor commands zero), within 5 cm of the take-off spot, without a crash.
TEST(FlightModes, TakesOffHoldsAndLandsOnTheTakeOffSpot) {
  SimFlight flight;
  const Eigen::Vector3d spot = flight.truth().p_W;
  ASSERT_TRUE(flight.vehicle().on_ground());
  ASSERT_TRUE(flight.TakeOffAndHold(1.0));
  const Eigen::Vector3d hold = flight.last_output().decision.setpoint.position_m;
  EXPECT_NEAR(hold.z(), spot.z() + 1.0, 0.02);
  double hold_error_m = 0.0;
  flight.StepUntil(
      [&] {
        hold_error_m = std::max(hold_error_m, (flight.truth().p_W - hold).norm());
        return false;
      },
      5.0);
  EXPECT_EQ(flight.mode(), FlightMode::kHold);
  EXPECT_LT(hold_error_m, 0.03);
  flight.Command(command_t::COMMAND_LAND);
  const double land_start_s = flight.now_s();
  ASSERT_TRUE(flight.StepUntil([&] { return flight.mode() == FlightMode::kIdle; }, 15.0));
  const double land_time_s = flight.now_s() - land_start_s;
  flight.StepFor(1.0);
  const Eigen::Vector3d end = flight.truth().p_W;
  std::printf(
      "simulator, take-off 1 m / hold 5 s / land: hold error max %.1f mm, landed (IDLE) after "
      "%.2f s, %.1f mm from the take-off spot horizontally, %.1f mm vertically\n",
      hold_error_m * 1e3, land_time_s, (end - spot).head<2>().norm() * 1e3,
      (end.z() - spot.z()) * 1e3);
  EXPECT_TRUE(flight.vehicle().on_ground());
  EXPECT_LT((end - spot).head<2>().norm(), 0.05);
  EXPECT_NEAR(end.z(), spot.z(), 0.01);
  EXPECT_EQ(flight.vehicle().collision_count(), 0);
  ASSERT_FALSE(flight.commands().empty());
  EXPECT_FALSE(flight.commands().back().armed);
  EXPECT_TRUE(flight.commands().back().rotor_thrust_N.isZero());
  EXPECT_LT(flight.truth().thrust_N.norm(), 1e-3);  // the rotors have stopped
}

// ESTOP while hovering: the first motor command stamped at or after the COMMAND's arrival (the
// same or the next control step) is disarmed with zero thrust, and so is every later one; the
// simulator's rotors spin down (first-order lag) and the vehicle falls.
TEST(FlightModes, EstopCutsMotorsInTheNextControlStep) {
  SimFlight flight;
  ASSERT_TRUE(flight.TakeOffAndHold(1.0));
  const size_t before = flight.commands().size();
  ASSERT_TRUE(flight.commands().back().armed);
  flight.Command(command_t::COMMAND_ESTOP);
  flight.StepFor(0.2);
  const int64_t arrival = flight.last_command_arrival_us();
  ASSERT_GE(arrival, 0);
  EXPECT_EQ(flight.mode(), FlightMode::kEstop);
  const auto& commands = flight.commands();
  size_t first_after = commands.size();
  for (size_t i = before; i < commands.size(); ++i) {
    if (commands[i].utime >= arrival) {
      first_after = i;
      break;
    }
  }
  ASSERT_LT(first_after, commands.size());
  EXPECT_LE(commands[first_after].utime - arrival, flight.period_us());
  EXPECT_TRUE(commands[first_after - 1].armed);  // armed up to the command
  for (size_t i = first_after; i < commands.size(); ++i) {
    EXPECT_FALSE(commands[i].armed) << i;
    EXPECT_TRUE(commands[i].rotor_thrust_N.isZero()) << i;
  }
  // After 0.2 s = 10 motor time constants the rotors are below 0.01% of hover thrust.
  EXPECT_LT(flight.truth().thrust_N.sum(), 1e-4 * 4.34 * 9.81);
  EXPECT_LT(flight.truth().v_W.z(), -1.0);  // falling
  std::printf("simulator, e-stop: first disarmed command %.2f ms after the COMMAND arrived\n",
              (commands[first_after].utime - arrival) * 1e-3);
}

// Tracking a 0.25 m/s line, motion capture is lost for 1 s (< land_timeout_s = 2 s): the
// controller holds on its IMU-propagated state (position error of the truth from the hold point
// stays within 10 cm, the estimate within 5 cm of the truth), does not land, and TRACK resumes
// within 50 ms of the poses' return; at the end the vehicle is within 3 cm of the line.
TEST(FlightModes, OneSecondMotionCaptureLossHoldsOnImuAndResumesTracking) {
  SimFlight flight;
  ASSERT_TRUE(flight.TakeOffAndHold(1.0));
  const double t0 = flight.now_s() + 0.2;
  const PiecewisePolynomialTrajectory line = Line(t0, flight.truth().p_W, 0.25, 8.0);
  flight.Publish(line);
  flight.StepFor(2.0);
  ASSERT_EQ(flight.mode(), FlightMode::kTrack);
  flight.LoseMotionCapture(0.0, 1.0);
  const double outage_start_s = flight.now_s();
  double hold_error_m = 0.0;
  double estimate_error_m = 0.0;
  bool held = false;
  bool landed_or_estop = false;
  double resumed_s = -1.0;
  flight.StepUntil(
      [&] {
        const FlightOutput& out = flight.last_output();
        const FlightMode mode = flight.mode();
        if (mode == FlightMode::kHold) {
          held = true;
          hold_error_m = std::max(hold_error_m,
                                  (flight.truth().p_W - out.decision.setpoint.position_m).norm());
        }
        if (mode == FlightMode::kLand || mode == FlightMode::kEstop) landed_or_estop = true;
        estimate_error_m =
            std::max(estimate_error_m, (out.state.position_m - flight.truth().p_W).norm());
        if (resumed_s < 0.0 && held && mode == FlightMode::kTrack) resumed_s = flight.now_s();
        return false;
      },
      2.0);
  const double resume_delay_s = resumed_s - (outage_start_s + 1.0);
  flight.StepUntil([] { return false; }, std::max(0.0, t0 + 8.0 - flight.now_s()));
  const double final_error_m =
      (flight.truth().p_W - line.Evaluate(flight.now_s()).position_m).norm();
  std::printf(
      "simulator, 1 s motion-capture loss while tracking: %lld poses dropped, hold error max %.1f "
      "mm, estimate error max %.1f mm, TRACK again %.0f ms after the poses returned, final "
      "error %.1f mm\n",
      static_cast<long long>(flight.poses_dropped()), hold_error_m * 1e3, estimate_error_m * 1e3,
      resume_delay_s * 1e3, final_error_m * 1e3);
  EXPECT_GE(flight.poses_dropped(), 99);
  EXPECT_TRUE(held);
  EXPECT_FALSE(landed_or_estop);
  EXPECT_LT(hold_error_m, 0.10);
  EXPECT_LT(estimate_error_m, 0.05);
  ASSERT_GT(resumed_s, 0.0);
  EXPECT_LT(resume_delay_s, 0.05);
  EXPECT_LT(final_error_m, 0.03);
  EXPECT_EQ(flight.vehicle().collision_count(), 0);
}

// Motion capture lost for good while hovering: HOLD after pose_timeout_s, LAND after
// land_timeout_s (2 s), on the IMU-propagated state: the vehicle reaches the floor without a
// crash (touchdown slower than 1 m/s) and disarms there (the blind landing of SafetyConfig;
// before it, the estimate's height drift made it disarm 0.2 m above the floor and crash), within
// 40 cm horizontally of where it hovered (IMU-only drift over 5 s: 28 cm measured).
TEST(FlightModes, MotionCaptureLostLongerThanLandTimeoutLands) {
  SimFlight flight;
  ASSERT_TRUE(flight.TakeOffAndHold(1.0));
  const Eigen::Vector3d hover = flight.truth().p_W;
  flight.LoseMotionCapture(0.0, 1e6);
  const double outage_start_s = flight.now_s();
  ASSERT_TRUE(flight.StepUntil([&] { return flight.mode() == FlightMode::kLand; }, 3.0));
  const double land_after_s = flight.now_s() - outage_start_s;
  EXPECT_NEAR(land_after_s, flight.config().flight.safety.land_timeout_s, 0.05);
  ASSERT_TRUE(flight.StepUntil([&] { return flight.vehicle().on_ground(); }, 10.0));
  const double touchdown_s = flight.now_s() - outage_start_s;
  flight.StepFor(3.0);
  const Eigen::Vector3d end = flight.truth().p_W;
  std::printf(
      "simulator, motion capture lost for good: LAND after %.2f s, on the floor after %.2f s, "
      "%.1f mm from the hover point horizontally, mode %s\n",
      land_after_s, touchdown_s, (end - hover).head<2>().norm() * 1e3, ToString(flight.mode()));
  EXPECT_TRUE(flight.vehicle().on_ground());
  EXPECT_LT((end - hover).head<2>().norm(), 0.4);
  EXPECT_EQ(flight.vehicle().collision_count(), 0);
  EXPECT_EQ(flight.mode(), FlightMode::kIdle);
  EXPECT_FALSE(flight.commands().back().armed);
}

// --- The controller killed in flight and respawned (docs/design.md §2.5). ---

// What a kill and a respawn did to the flight.
struct RestartFigures {
  double time_to_hold_s{-1};    // kill -> the new controller in HOLD (-1: never)
  double height_lost_m{0};      // height at the kill - lowest true height after it
  double max_speed_after_s{0};  // largest true speed in the last second (2 s after the takeover)
  double excursion_m{0};        // farthest the true vehicle went outside the geofence, m
  int collisions{0};
  bool armed_after_restart{false};  // any armed motor command from the new controller
  FlightMode final_mode{FlightMode::kIdle};
  std::string status;  // the new controller's takeover status
};

// Flies a line in TRACK at 0.5 m/s, kills the controller, lets `gap_s` of simulated time pass
// without motor commands (the runner's respawn), starts a controller with run id `new_run_id` and
// the same state file, and flies 3 s more.
RestartFigures KillAndRespawnController(double gap_s, const std::string& new_run_id) {
  SimFlight flight;
  char dir[] = "/tmp/kestrel-controller-restart-XXXXXX";
  EXPECT_NE(mkdtemp(dir), nullptr);
  ControllerConfig config = flight.config();
  config.state_path = std::string(dir) + "/controller.state";
  config.run_id = "run-a";
  flight.StartController(config);
  RestartFigures fig;
  EXPECT_TRUE(flight.TakeOffAndHold(0.8));
  const Eigen::Vector3d start = flight.last_output().decision.setpoint.position_m;
  flight.Publish(Line(flight.now_s(), start, 0.5, 3.0));
  flight.StepFor(1.0);
  EXPECT_EQ(flight.mode(), FlightMode::kTrack);
  const double z_kill = flight.truth().p_W.z();
  const double t_kill = flight.now_s();
  const Eigen::Vector3d lo = config.flight.safety.geofence_min_m;
  const Eigen::Vector3d hi = config.flight.safety.geofence_max_m;
  double z_min = z_kill;
  auto watch = [&] {
    const Eigen::Vector3d p = flight.truth().p_W;
    z_min = std::min(z_min, p.z());
    fig.excursion_m = std::max({fig.excursion_m, (lo - p).maxCoeff(), (p - hi).maxCoeff()});
  };
  flight.KillController();
  const size_t commands_before = flight.commands().size();
  flight.StepUntil(
      [&] {
        watch();
        return false;
      },
      gap_s);
  config.run_id = new_run_id;
  flight.StartController(config);
  fig.status = flight.controller().takeover_status();
  flight.StepUntil(
      [&] {
        watch();
        if (fig.time_to_hold_s < 0 && flight.mode() == FlightMode::kHold) {
          fig.time_to_hold_s = flight.now_s() - t_kill;
        }
        return false;
      },
      2.0);
  flight.StepUntil(
      [&] {
        watch();
        fig.max_speed_after_s = std::max(fig.max_speed_after_s, flight.truth().v_W.norm());
        return false;
      },
      1.0);
  fig.status = flight.controller().takeover_status();
  fig.height_lost_m = z_kill - z_min;
  fig.collisions = flight.vehicle().collision_count();
  fig.final_mode = flight.mode();
  for (size_t i = commands_before; i < flight.commands().size(); ++i) {
    fig.armed_after_restart = fig.armed_after_restart || flight.commands()[i].armed;
  }
  std::remove(config.state_path.c_str());
  rmdir(dir);
  std::printf(
      "respawn gap %.2f s, run %s: time to HOLD %.3f s after the kill, height lost %.3f m, "
      "speed after %.3f m/s, excursion %.3f m, collisions %d, mode %s (%s)\n",
      gap_s, new_run_id.c_str(), fig.time_to_hold_s, fig.height_lost_m, fig.max_speed_after_s,
      fig.excursion_m, fig.collisions, ToString(fig.final_mode), fig.status.c_str());
  return fig;
}

// The respawn gap the runner gives the controller: respawn_backoff_min_s = 0.5 s, plus its poll
// period (0.1 s) and the process's start-up, bounded at 1 s of simulated time at speed 1.
constexpr double kRespawnGapS = 1.0;

// Same run: the new controller holds where the vehicle is, within the sim's ESC watchdog
// (motor_command_timeout_s, config/sim/sim_ci.yaml), without touching the floor.
TEST(ControllerRestart, SameRunTakesTheFlyingVehicleOverInHold) {
  const RestartFigures f = KillAndRespawnController(kRespawnGapS, "run-a");
  EXPECT_EQ(f.final_mode, FlightMode::kHold) << f.status;
  EXPECT_GT(f.time_to_hold_s, 0.0) << f.status;
  EXPECT_LT(f.time_to_hold_s, kRespawnGapS + 0.1) << "HOLD within 0.1 s of the respawn";
  EXPECT_LT(f.height_lost_m, 0.15);
  EXPECT_LT(f.max_speed_after_s, 0.1) << "the vehicle holds still";
  EXPECT_LE(f.excursion_m, 0.0) << "never outside the geofence";
  EXPECT_EQ(f.collisions, 0);
}

// Another run (a new runner, or no run id): the new controller never arms itself; it stays IDLE
// with the motors off.
TEST(ControllerRestart, AnotherRunStaysIdleAndDisarmed) {
  const RestartFigures f = KillAndRespawnController(kRespawnGapS, "run-b");
  EXPECT_EQ(f.final_mode, FlightMode::kIdle) << f.status;
  EXPECT_FALSE(f.armed_after_restart);
  EXPECT_NE(f.status.find("belongs to run run-a"), std::string::npos) << f.status;
}

// How the gap and the ESC watchdog trade (figures for docs/design.md §2.5).
TEST(ControllerRestart, HeightLostAgainstTheRespawnGap) {
  for (double gap : {0.3, 0.6, 0.8, 1.0, 1.2, 1.4, 1.6}) KillAndRespawnController(gap, "run-a");
}

}  // namespace
}  // namespace kestrel

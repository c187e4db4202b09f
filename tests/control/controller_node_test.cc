// The controller node over LCM memq:// with a simulated clock, closing the loop through the
// rigid-body model: messages in (pose, IMU, command, trajectory), motor commands and status out.
#include "control/controller_node.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <deque>
#include <fstream>
#include <vector>

#include "common/clock.h"
#include "common/config.h"
#include "common/lcm_decode.h"
#include "common/run_state_file.h"
#include "control/rigid_body.h"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/motor_command_t.hpp"

namespace kestrel {
namespace {

constexpr int64_t kTickUs = 2500;  // 400 Hz
constexpr int64_t kTestEpoch = 3;  // the test's publisher epoch

class ControllerNodeTest : public ::testing::Test {
 protected:
  ControllerNodeTest()
      : lcm_("memq://"),
        clock_(1'000'000'000),
        node_(lcm_, config_, clock_),
        sim_(config_.flight.vehicle),
        outputs_(lcm_) {
    sim_.EnableGround(0.0);
    outputs_.Add<motor_command_t>(
        "MOTOR_COMMAND",
        [this](const std::string&, const motor_command_t& m) {
          motor_ = m;
          ++motors_;
        },
        nullptr);
    outputs_.Add<controller_status_t>(
        "CONTROLLER_STATUS",
        [this](const std::string&, const controller_status_t& s) {
          status_ = s;
          ++statuses_;
        },
        nullptr);
  }

  void Dispatch() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

  // Sensors from the model (poses every 10 ms), dispatch, tick, apply the motor command.
  void Advance(double duration_s) {
    const int steps = static_cast<int>(std::lround(duration_s * 1e6 / kTickUs));
    for (int k = 0; k < steps; ++k) {
      const int64_t now = clock_.NowUtime();
      const VehicleState truth = sim_.state();
      if ((now / kTickUs) % 4 == 0) {
        pose_t pose;
        pose.utime = now;
        pose.seq = pose_seq_++;
        pose.epoch = kTestEpoch;
        pose.frame_id = "world";
        pose.child_frame_id = "kestrel";
        pose.valid = true;
        const Eigen::Quaterniond q(truth.R_WB);
        for (int i = 0; i < 3; ++i) pose.position_m[i] = truth.position_m[i];
        pose.orientation_wxyz[0] = q.w();
        pose.orientation_wxyz[1] = q.x();
        pose.orientation_wxyz[2] = q.y();
        pose.orientation_wxyz[3] = q.z();
        pose.has_velocity = false;
        for (int i = 0; i < 3; ++i) pose.velocity_mps[i] = pose.angular_velocity_radps[i] = 0.0;
        lcm_.publish("POSE_VICON", &pose);
      }
      imu_t imu;
      imu.utime = now;
      imu.seq = imu_seq_++;
      imu.epoch = kTestEpoch;
      imu.sensor_name = "imu";
      const Eigen::Vector3d f = sim_.specific_force_B_mps2();
      for (int i = 0; i < 3; ++i) {
        imu.angular_velocity_radps[i] = truth.angular_velocity_radps[i];
        imu.specific_force_mps2[i] = f[i];
      }
      lcm_.publish("IMU", &imu);
      Dispatch();
      node_.Tick(now);
      Dispatch();
      Eigen::Vector4d thrust = Eigen::Vector4d::Zero();
      if (motors_ > 0 && motor_.armed && motor_.num_motors == 4) {
        for (int i = 0; i < 4; ++i) thrust[i] = motor_.thrust_N[static_cast<size_t>(i)];
      }
      sim_.Step(thrust, kTickUs * 1e-6);
      clock_.AdvanceUtime(kTickUs);
    }
  }

  void SendCommand(int8_t command) {
    command_t msg;
    msg.utime = clock_.NowUtime();
    msg.seq = 0;
    msg.epoch = kTestEpoch;
    msg.source = "test";
    msg.command = command;
    msg.height_m = 1.2;
    lcm_.publish("COMMAND", &msg);
    Dispatch();
  }

  lcm::LCM lcm_;
  ControllerConfig config_;
  SimClock clock_;
  ControllerNode node_;
  RigidBodySimulator sim_;
  GuardedSubscriptions outputs_;
  motor_command_t motor_;
  controller_status_t status_;
  int motors_ = 0;
  int statuses_ = 0;
  int64_t pose_seq_ = 0;
  int64_t imu_seq_ = 0;
};

// Take-off through the COMMAND channel to 1.2 m, then a trajectory over TRAJECTORY is tracked.
TEST_F(ControllerNodeTest, TakesOffAndTracksOverLcm) {
  ASSERT_TRUE(lcm_.good());
  Advance(0.5);
  EXPECT_GT(motors_, 0);
  EXPECT_FALSE(motor_.armed);
  SendCommand(command_t::COMMAND_TAKEOFF);
  Advance(5.0);
  EXPECT_EQ(status_.mode, controller_status_t::MODE_HOLD) << status_.reason;
  EXPECT_TRUE(motor_.armed);
  EXPECT_EQ(motor_.num_motors, 4);
  EXPECT_LT((sim_.state().position_m - Eigen::Vector3d(0, 0, 1.2)).norm(), 0.03);
  EXPECT_NEAR(status_.position_m[2], sim_.state().position_m.z(), 0.01);
  EXPECT_GT(statuses_, 100);

  trajectory_t trajectory;
  trajectory.utime = clock_.NowUtime();
  trajectory.seq = 7;
  trajectory.epoch = 0x7e57;
  trajectory.start_utime = clock_.NowUtime();
  trajectory.num_segments = 1;
  trajectory.num_coeffs = 4;
  trajectory.durations_s = {4.0};
  // Rest-to-rest cubic from (0, 0, 1.2) to (1, -0.5, 1.2).
  trajectory.coeffs_x = {{0.0, 0.0, 3.0 * 1.0 / 16.0, -2.0 * 1.0 / 64.0}};
  trajectory.coeffs_y = {{0.0, 0.0, 3.0 * -0.5 / 16.0, -2.0 * -0.5 / 64.0}};
  trajectory.coeffs_z = {{1.2, 0.0, 0.0, 0.0}};
  trajectory.coeffs_yaw = {{0.0, 0.0, 0.0, 0.0}};
  lcm_.publish("TRAJECTORY", &trajectory);
  Dispatch();
  Advance(1.0);
  EXPECT_EQ(status_.mode, controller_status_t::MODE_TRACK) << status_.reason;
  EXPECT_EQ(status_.trajectory_seq, 7);
  EXPECT_EQ(status_.trajectory_epoch, 0x7e57) << "whose trajectory 7 it is";
  Advance(4.0);
  EXPECT_TRUE(status_.trajectory_done);
  EXPECT_LT((sim_.state().position_m - Eigen::Vector3d(1.0, -0.5, 1.2)).norm(), 0.03);
}

// E-stop over COMMAND: the next motor command is disarmed with zero thrust.
TEST_F(ControllerNodeTest, EstopOverLcmDisarmsAtOnce) {
  Advance(0.3);
  SendCommand(command_t::COMMAND_TAKEOFF);
  Advance(1.0);
  ASSERT_TRUE(motor_.armed);
  SendCommand(command_t::COMMAND_ESTOP);
  const int before = motors_;
  Advance(kTickUs * 1e-6);
  EXPECT_EQ(motors_, before + 1);
  EXPECT_FALSE(motor_.armed);
  for (double t : motor_.thrust_N) EXPECT_EQ(t, 0.0);
}

// Garbage bytes, invalid poses and bad commands are counted and dropped, never applied.
TEST_F(ControllerNodeTest, CountsAndDropsBadInput) {
  const char garbage[] = "not an lcm message at all";
  lcm_.publish("POSE_VICON", garbage, sizeof(garbage));
  pose_t invalid;
  invalid.utime = clock_.NowUtime();
  invalid.seq = 0;
  invalid.epoch = kTestEpoch;
  invalid.frame_id = "world";
  invalid.child_frame_id = "kestrel";
  invalid.valid = false;
  lcm_.publish("POSE_VICON", &invalid);
  command_t bad;
  bad.utime = 0;
  bad.seq = 0;
  bad.epoch = kTestEpoch;
  bad.source = "test";
  bad.command = 42;
  bad.height_m = 0.0;
  lcm_.publish("COMMAND", &bad);
  Dispatch();
  EXPECT_EQ(node_.drops().count("malformed"), 1);
  EXPECT_EQ(node_.drops().count("invalid pose"), 1);
  EXPECT_EQ(node_.drops().count("invalid command"), 1);
  EXPECT_FALSE(node_.flight().estimator().initialized());
  // Take-off without any pose is refused.
  SendCommand(command_t::COMMAND_TAKEOFF);
  EXPECT_EQ(node_.drops().count("refused command"), 1);
}

// The process configuration from YAML: values land in their fields; errors name file and key.
TEST(LoadControllerConfig, ReadsKeysAndNamesErrors) {
  const VehicleConfig vehicle;
  const ControllerConfig config = LoadControllerConfig(
      ConfigNode::FromString("rate_hz: 250\nchannels:\n  pose: POSE_SIM\ncontroller:\n"
                             "  k_x_per_s2: 12.0\n  attitude_error: cdc2010\n  max_tilt_rad: 0.8\n"
                             "safety:\n  land_timeout_s: 3.0\n  blind_land_depth_m: 0.7\n"
                             "  geofence_max_m: [5, 5, 3]\n  max_trajectory_start_offset_m: 0.2\n"
                             "state_path: /tmp/c.state\nrun_id: run-7\ntakeover_max_gap_s: 2\n",
                             "controller.yaml"),
      vehicle);
  EXPECT_EQ(config.rate_hz, 250.0);
  EXPECT_EQ(config.pose_channel, "POSE_SIM");
  EXPECT_EQ(config.imu_channel, "IMU");
  EXPECT_EQ(config.flight.controller.k_x_per_s2, 12.0);
  EXPECT_EQ(config.flight.controller.attitude_error, AttitudeErrorForm::kCdc2010);
  EXPECT_EQ(config.flight.controller.max_tilt_rad, 0.8);
  EXPECT_EQ(config.flight.safety.land_timeout_s, 3.0);
  EXPECT_EQ(config.flight.safety.blind_land_depth_m, 0.7);
  // The default attitude error is the large-angle one.
  EXPECT_EQ(LoadControllerConfig(ConfigNode::FromString("rate_hz: 250\n", "c.yaml"), vehicle)
                .flight.controller.attitude_error,
            AttitudeErrorForm::kLargeAngle);
  EXPECT_EQ(config.flight.safety.geofence_max_m, Eigen::Vector3d(5, 5, 3));
  EXPECT_EQ(config.flight.safety.max_trajectory_start_offset_m, 0.2);
  EXPECT_EQ(config.state_path, "/tmp/c.state");
  EXPECT_EQ(config.run_id, "run-7");
  EXPECT_EQ(config.takeover_max_gap_s, 2.0);
  for (const char* bad :
       {"rate_hz: 5\n", "controller:\n  k_R_Nm_per_rad: -1\n",
        "controller:\n  attitude_error: lee\n", "safety:\n  blind_land_depth_m: 0.2\n",
        "safety:\n  pose_timeout_s: 5\n", "typo_key: 1\n", "run_id: 'a b'\n",
        "takeover_max_gap_s: 0\n", "safety:\n  max_trajectory_start_offset_m: 0\n"}) {
    try {
      (void)LoadControllerConfig(ConfigNode::FromString(bad, "controller.yaml"), vehicle);
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("controller.yaml"), std::string::npos) << e.what();
    }
  }
}

// Motor commands and status carry their publisher's epoch; a second controller in the process has
// other epochs.
TEST_F(ControllerNodeTest, StampsItsEpochs) {
  Advance(0.1);
  ASSERT_GT(motors_, 0);
  ASSERT_GT(statuses_, 0);
  EXPECT_NE(motor_.epoch, 0);
  EXPECT_EQ(status_.epoch, node_.epoch());
  EXPECT_NE(status_.epoch, 0);
  EXPECT_EQ(status_.trajectory_epoch, 0) << "no trajectory yet";
  const int64_t motor_epoch = motor_.epoch;
  ControllerConfig second_config = config_;
  second_config.motor_channel = "MOTOR_COMMAND_2";
  second_config.status_channel = "CONTROLLER_STATUS_2";
  ControllerNode second(lcm_, second_config, clock_);
  motor_command_t second_motor{};
  GuardedSubscriptions subs(lcm_);
  subs.Add<motor_command_t>(
      "MOTOR_COMMAND_2", [&](const std::string&, const motor_command_t& m) { second_motor = m; },
      nullptr);
  second.Tick(clock_.NowUtime());
  Dispatch();
  EXPECT_NE(second.epoch(), node_.epoch());
  EXPECT_NE(second_motor.epoch, 0);
  EXPECT_NE(second_motor.epoch, motor_epoch);
}

}  // namespace
}  // namespace kestrel

namespace kestrel {
namespace {

// The flight-state file at start-up (docs/design.md §2.5): a corrupt file is refused with the
// reason and the controller starts IDLE and disarmed; an e-stop of the same run stays latched; the
// first control step rewrites the file with this controller's run and mode.
TEST(ControllerStateFile, CorruptRefusedEstopLatchedFileRewritten) {
  char dir[] = "/tmp/kestrel-controller-node-XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  ControllerConfig config;
  config.state_path = std::string(dir) + "/controller.state";
  config.run_id = "run-a";
  lcm::LCM lcm("memq://");
  SimClock clock(1'000'000'000);
  {
    std::ofstream(config.state_path) << "kestrel-state controller 1\nrun_id run-a\nmode HOLD\n";
    ControllerNode node(lcm, config, clock);
    EXPECT_NE(node.takeover_status().find("state file refused"), std::string::npos)
        << node.takeover_status();
    node.Tick(clock.NowUtime());
    EXPECT_EQ(node.flight().supervisor().mode(), FlightMode::kIdle);
    EXPECT_FALSE(node.last_output().armed);
  }
  RunStateFile file;
  std::string error;
  ASSERT_EQ(ReadRunStateFile(config.state_path, "controller", "run-a", &file, &error),
            RunStateRead::kOk)
      << error;
  EXPECT_EQ(*file.Find("mode"), "IDLE") << "rewritten at the first control step";
  file.values["mode"] = "ESTOP";
  ASSERT_TRUE(WriteRunStateFile(config.state_path, file, &error)) << error;
  {
    ControllerNode node(lcm, config, clock);
    node.Tick(clock.NowUtime());
    EXPECT_EQ(node.flight().supervisor().mode(), FlightMode::kEstop) << node.takeover_status();
    EXPECT_FALSE(node.last_output().armed);
  }
  std::remove(config.state_path.c_str());
  rmdir(dir);
}

}  // namespace
}  // namespace kestrel

namespace kestrel {
namespace {

// A controller respawned within the run (docs/design.md §2.5): its predecessor's state file says
// HOLD; IMU samples come at once, the first pose only `pose_late_s` after the respawn. Until that
// pose the new controller sends no motor command and no status (the ESC hold keeps the
// predecessor's last command); on the next control step it takes the vehicle over, however late
// the pose came.
class ControllerTakeoverTest : public ::testing::Test {
 protected:
  ControllerTakeoverTest() : lcm_("memq://"), clock_(50'000'000), outputs_(lcm_) {
    char dir[] = "/tmp/kestrel-takeover-XXXXXX";
    EXPECT_NE(mkdtemp(dir), nullptr);
    dir_ = dir;
    config_.state_path = dir_ + "/controller.state";
    config_.run_id = "run-a";
    outputs_.Add<motor_command_t>(
        "MOTOR_COMMAND",
        [this](const std::string&, const motor_command_t& m) { motors_.push_back(m); }, nullptr);
    outputs_.Add<controller_status_t>(
        "CONTROLLER_STATUS",
        [this](const std::string&, const controller_status_t& s) { statuses_.push_back(s); },
        nullptr);
  }
  ~ControllerTakeoverTest() override {
    std::remove(config_.state_path.c_str());
    rmdir(dir_.c_str());
  }

  // The predecessor's file: `mode`, last written at the current time (its last life sign).
  void WritePredecessorFile(const std::string& mode) {
    RunStateFile file;
    file.kind = "controller";
    file.run_id = "run-a";
    file.values["mode"] = mode;
    file.values["ground_z_m"] = "0";
    file.values["utime"] = std::to_string(clock_.NowUtime());
    std::string error;
    ASSERT_TRUE(WriteRunStateFile(config_.state_path, file, &error)) << error;
  }

  // Steps `node` for duration_s at 400 Hz: an IMU sample every step (hovering), a pose at
  // `z_m` every 4th step once the clock reaches pose_from_utime.
  void Run(ControllerNode* node, double duration_s, int64_t pose_from_utime, double z_m) {
    const int steps = static_cast<int>(std::lround(duration_s * 1e6 / kTickUs));
    for (int k = 0; k < steps; ++k) {
      const int64_t now = clock_.NowUtime();
      imu_t imu{};
      imu.utime = now;
      imu.seq = seq_++;
      imu.epoch = kTestEpoch;
      imu.specific_force_mps2[2] = 9.81;
      lcm_.publish("IMU", &imu);
      if (now >= pose_from_utime && (now / kTickUs) % 4 == 0) {
        pose_t pose{};
        pose.utime = now;
        pose.seq = seq_++;
        pose.epoch = kTestEpoch;
        pose.valid = true;
        pose.position_m[2] = z_m;
        pose.orientation_wxyz[0] = 1.0;
        lcm_.publish("POSE_VICON", &pose);
      }
      while (lcm_.handleTimeout(0) > 0) {
      }
      node->Tick(now);
      while (lcm_.handleTimeout(0) > 0) {
      }
      clock_.AdvanceUtime(kTickUs);
    }
  }

  void SendCommand(int8_t command) {
    command_t msg{};
    msg.utime = clock_.NowUtime();
    msg.epoch = kTestEpoch;
    msg.source = "test";
    msg.command = command;
    lcm_.publish("COMMAND", &msg);
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

  lcm::LCM lcm_;
  SimClock clock_;
  ControllerConfig config_;
  GuardedSubscriptions outputs_;
  std::string dir_;
  std::vector<motor_command_t> motors_;
  std::vector<controller_status_t> statuses_;
  int64_t seq_{0};
};

TEST_F(ControllerTakeoverTest, FirstPoseLateBySecondsStillTakesTheFlyingVehicleOver) {
  for (const double late_s : {0.5, 1.0, 2.0, 5.0}) {
    SCOPED_TRACE(late_s);
    motors_.clear();
    statuses_.clear();
    WritePredecessorFile("TRACK");
    clock_.AdvanceUtime(SecondsToUtime(0.3));  // the respawn
    ControllerNode node(lcm_, config_, clock_);
    const int64_t pose_from = clock_.NowUtime() + SecondsToUtime(late_s);
    Run(&node, late_s, pose_from, 1.0);
    EXPECT_TRUE(node.takeover_pending()) << node.takeover_status();
    EXPECT_TRUE(motors_.empty()) << "no motor command before the pose decides";
    EXPECT_TRUE(statuses_.empty()) << "no status claims a mode before the pose decides";
    Run(&node, 0.1, pose_from, 1.0);
    ASSERT_FALSE(node.takeover_pending()) << node.takeover_status();
    EXPECT_EQ(node.flight().supervisor().mode(), FlightMode::kHold) << node.takeover_status();
    ASSERT_GE(node.first_pose_utime(), pose_from);
    EXPECT_LE(node.takeover_utime() - node.first_pose_utime(), kTickUs)
        << "decided on the first control step after the first pose";
    ASSERT_FALSE(motors_.empty());
    EXPECT_TRUE(motors_.front().armed);
    ASSERT_FALSE(statuses_.empty());
    EXPECT_EQ(statuses_.front().mode, controller_status_t::MODE_HOLD);
    std::printf("first pose %.1f s late: %s\n", late_s, node.takeover_status().c_str());
  }
}

// The first pose shows the vehicle on its take-off ground: IDLE, disarmed, and the file says so.
TEST_F(ControllerTakeoverTest, OnTheGroundStaysIdleAndRewritesTheFile) {
  WritePredecessorFile("HOLD");
  ControllerNode node(lcm_, config_, clock_);
  Run(&node, 0.2, clock_.NowUtime() + SecondsToUtime(0.1), 0.02);
  EXPECT_FALSE(node.takeover_pending());
  EXPECT_EQ(node.flight().supervisor().mode(), FlightMode::kIdle);
  ASSERT_FALSE(motors_.empty());
  EXPECT_FALSE(motors_.back().armed);
  EXPECT_NE(node.takeover_status().find("on the ground"), std::string::npos);
  RunStateFile file;
  ASSERT_EQ(ReadRunStateFile(config_.state_path, "controller", "run-a", &file, nullptr),
            RunStateRead::kOk);
  EXPECT_EQ(*file.Find("mode"), "IDLE");
}

// While the verdict is pending only an e-stop acts (motors off at once); a land order is kept
// and the takeover then lands; anything else is refused and counted.
TEST_F(ControllerTakeoverTest, CommandsWhileTheTakeoverIsPending) {
  WritePredecessorFile("HOLD");
  {
    ControllerNode node(lcm_, config_, clock_);
    const int64_t pose_from = clock_.NowUtime() + SecondsToUtime(1.0);
    Run(&node, 0.2, pose_from, 1.0);
    SendCommand(command_t::COMMAND_TAKEOFF);
    EXPECT_EQ(node.drops().count("refused command"), 1);
    SendCommand(command_t::COMMAND_LAND);
    Run(&node, 1.0, pose_from, 1.0);
    EXPECT_EQ(node.flight().supervisor().mode(), FlightMode::kLand) << node.takeover_status();
  }
  motors_.clear();
  WritePredecessorFile("HOLD");
  ControllerNode node(lcm_, config_, clock_);
  Run(&node, 0.2, clock_.NowUtime() + SecondsToUtime(1.0), 1.0);
  SendCommand(command_t::COMMAND_ESTOP);
  Run(&node, 0.01, clock_.NowUtime() + SecondsToUtime(1.0), 1.0);
  EXPECT_FALSE(node.takeover_pending());
  EXPECT_EQ(node.flight().supervisor().mode(), FlightMode::kEstop);
  ASSERT_FALSE(motors_.empty());
  EXPECT_FALSE(motors_.back().armed);
}

// In flight the file's stamp is refreshed every half second: a respawn judges its evidence by
// the predecessor's last life sign, not by when the mode last changed.
TEST_F(ControllerTakeoverTest, TheFileStampIsALifeSignInFlight) {
  WritePredecessorFile("HOLD");
  ControllerNode node(lcm_, config_, clock_);
  Run(&node, 2.0, clock_.NowUtime(), 1.0);
  ASSERT_EQ(node.flight().supervisor().mode(), FlightMode::kHold);
  RunStateFile file;
  ASSERT_EQ(ReadRunStateFile(config_.state_path, "controller", "run-a", &file, nullptr),
            RunStateRead::kOk);
  double utime = 0;
  ASSERT_TRUE(file.GetDouble("utime", &utime));
  EXPECT_GE(utime, static_cast<double>(clock_.NowUtime() - SecondsToUtime(0.5) - kTickUs));
}

}  // namespace
}  // namespace kestrel

// The explorer node over memq://: its messages carry its publisher epoch, and it tells its own
// trajectory from a predecessor's with the same number (docs/design.md §3.4).
#include "exploration/explorer_node.h"

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "common/config.h"
#include "common/lcm_decode.h"
#include "common/trajectory_message.h"
#include "kestrel/controller_status_t.hpp"
#include "kestrel/map3d_chunk_t.hpp"
#include "kestrel/pose_t.hpp"
#include "kestrel/trajectory_t.hpp"
#include "lcmtypes/message_codecs.h"

namespace kestrel {
namespace {

class ExplorerNodeTest : public ::testing::Test {
 protected:
  ExplorerNodeTest() {
    config_.explorer.map.min_m = Eigen::Vector3d(-2.0, -2.0, -0.15);
    config_.explorer.map.max_m = Eigen::Vector3d(2.0, 2.0, 1.5);
    config_.explorer.map.resolution_m = 0.1;
    subs_.Add<trajectory_t>(
        config_.trajectory_channel,
        [this](const std::string&, const trajectory_t& m) { trajectories_.push_back(m); }, nullptr);
  }

  void Dispatch() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

  // An empty map snapshot (prior p_init, the explorer's by default), a pose at the exploration
  // height and the controller in `mode` tracking trajectory (seq, epoch).
  void SendWorld(int8_t mode, int64_t trajectory_seq, int64_t trajectory_epoch,
                 double p_init = -1.0) {
    map3d_chunk_t chunk{};
    chunk.utime = clock_.NowUtime();
    chunk.snapshot_id = 1;
    chunk.epoch = 11;
    chunk.num_chunks = 1;
    for (int a = 0; a < 3; ++a) chunk.origin_m[a] = config_.explorer.map.min_m[a];
    chunk.resolution_m = config_.explorer.map.resolution_m;
    // As the mapper sends it: the prior its float cells hold.
    chunk.p_init = p_init > 0 ? p_init : static_cast<float>(config_.explorer.p_init);
    chunk.block_edge = 8;
    EncodeMapChunkCells({}, map3d_chunk_t::ENCODING_FLOAT32, 0, &chunk);
    lcm_.publish(config_.map_channel, &chunk);
    pose_t pose{};
    pose.utime = clock_.NowUtime();
    pose.epoch = 12;
    pose.frame_id = "world";
    pose.child_frame_id = "kestrel";
    pose.valid = true;
    pose.position_m[2] = config_.explorer.planner.projection.height_m;
    pose.orientation_wxyz[0] = 1.0;
    lcm_.publish(config_.pose_channel, &pose);
    controller_status_t status{};
    status.utime = clock_.NowUtime();
    status.epoch = 13;
    status.mode = mode;
    status.trajectory_seq = trajectory_seq;
    status.trajectory_epoch = trajectory_epoch;
    lcm_.publish(config_.controller_channel, &status);
    Dispatch();
  }

  ExplorerNodeConfig config_;
  lcm::LCM lcm_{"memq://"};
  SimClock clock_{1'000'000'000};
  GuardedSubscriptions subs_{lcm_};
  std::vector<trajectory_t> trajectories_;
};

// The start-up turn goes out stamped with the explorer's epoch; the controller flying trajectory
// 1 of another explorer (one that ran before a restart) is not flying ours, so ours counts as
// not flown; when the controller names our epoch it is flown.
TEST_F(ExplorerNodeTest, TellsItsTrajectoryFromAPredecessorsWithTheSameSeq) {
  for (const bool predecessor : {true, false}) {
    SCOPED_TRACE(predecessor ? "the controller flies a predecessor's trajectory 1"
                             : "the controller flies ours");
    trajectories_.clear();
    ExplorerNode node(lcm_, config_, clock_);
    EXPECT_NE(node.epoch(), 0);
    SendWorld(controller_status_t::MODE_HOLD, -1, 0);
    node.Step();
    Dispatch();
    ASSERT_EQ(node.state(), ExplorerState::kStartup) << node.drops().last_reason();
    ASSERT_EQ(trajectories_.size(), 1u);
    EXPECT_EQ(trajectories_[0].seq, 1);
    EXPECT_EQ(trajectories_[0].epoch, node.epoch());
    const int64_t flown_epoch = predecessor ? node.epoch() + 1 : node.epoch();
    for (int i = 0; i < 20; ++i) {  // 2 s, past the 1 s the controller has to take it
      clock_.AdvanceUtime(100000);
      SendWorld(controller_status_t::MODE_TRACK, 1, flown_epoch);
      node.Step();
    }
    EXPECT_EQ(node.explorer().count(ExplorerEvent::kStartupNotFlown), predecessor ? 1 : 0);
    EXPECT_EQ(node.drops().total(), 0) << "an event, not a drop";
    EXPECT_EQ(node.state(), predecessor ? ExplorerState::kWaiting : ExplorerState::kStartup);
  }
}

// Restarts (docs/design.md §2.5): an explorer of the same run finds its predecessor's state file
// (written at the start-up) and, the vehicle airborne, explores at once without a start-up turn;
// an explorer of another run, or one finding a corrupt file, starts as on a first start.
TEST_F(ExplorerNodeTest, ResumesFromItsStateFileOnlyInTheSameRun) {
  char dir[] = "/tmp/kestrel-explorer-node-XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  config_.state_path = std::string(dir) + "/explorer.state";
  config_.run_id = "run-a";
  {
    ExplorerNode first(lcm_, config_, clock_);
    SendWorld(controller_status_t::MODE_HOLD, -1, 0);
    first.Step();
    ASSERT_EQ(first.state(), ExplorerState::kStartup);
  }
  {
    ExplorerNode same_run(lcm_, config_, clock_);
    EXPECT_NE(same_run.resume_status().find("(was startup)"), std::string::npos)
        << same_run.resume_status();
    clock_.AdvanceUtime(100000);
    SendWorld(controller_status_t::MODE_HOLD, -1, 0);
    same_run.Step();
    EXPECT_EQ(same_run.state(), ExplorerState::kExploring) << same_run.resume_status();
    EXPECT_EQ(same_run.resume_status().rfind("resumed startup from the flown state", 0), 0u)
        << same_run.resume_status();
  }
  config_.run_id = "run-b";
  {
    ExplorerNode other_run(lcm_, config_, clock_);
    SendWorld(controller_status_t::MODE_HOLD, -1, 0);
    other_run.Step();
    EXPECT_EQ(other_run.state(), ExplorerState::kStartup) << other_run.resume_status();
  }
  std::ofstream(config_.state_path) << "kestrel-state explorer 1\nrun_id run-b\nstate EXPLORING\n";
  {
    ExplorerNode corrupt(lcm_, config_, clock_);
    EXPECT_NE(corrupt.resume_status().find("corrupt state file"), std::string::npos)
        << corrupt.resume_status();
    SendWorld(controller_status_t::MODE_HOLD, -1, 0);
    corrupt.Step();
    EXPECT_EQ(corrupt.state(), ExplorerState::kStartup);
  }
  std::remove(config_.state_path.c_str());
  rmdir(dir);
}

// A snapshot from a mapper with another prior is refused, said why, and counted; the explorer
// waits for a map it can use.
TEST_F(ExplorerNodeTest, RefusesAMapWithAnotherPrior) {
  ExplorerNode node(lcm_, config_, clock_);
  SendWorld(controller_status_t::MODE_HOLD, -1, 0, 0.2);
  node.Step();
  EXPECT_EQ(node.drops().count("map_prior"), 1);
  EXPECT_NE(node.drops().last_reason().find("map.p_init"), std::string::npos);
  EXPECT_FALSE(node.replica().current());
  EXPECT_EQ(node.state(), ExplorerState::kWaiting);
  SendWorld(controller_status_t::MODE_HOLD, -1, 0);
  node.Step();
  EXPECT_EQ(node.state(), ExplorerState::kStartup);
}

// Two explorers in one process are two publishers.
TEST_F(ExplorerNodeTest, TwoNodesHaveDifferentEpochs) {
  ExplorerNode a(lcm_, config_, clock_);
  ExplorerNode b(lcm_, config_, clock_);
  EXPECT_NE(a.epoch(), 0);
  EXPECT_NE(b.epoch(), 0);
  EXPECT_NE(a.epoch(), b.epoch());
}

}  // namespace
}  // namespace kestrel

namespace kestrel {
namespace {

// A straight flight from a to b in duration_s from start_s.
PiecewisePolynomialTrajectory Straight(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       double start_s, double duration_s) {
  PolynomialSegment s;
  s.duration_s = duration_s;
  for (int i = 0; i < 3; ++i) s.coefficients[i] = {a[i], (b[i] - a[i]) / duration_s};
  s.coefficients[3] = {0.0};
  return *PiecewisePolynomialTrajectory::Create(start_s, {s}, nullptr);
}

// Several vehicles (docs/exploration.md, "Several vehicles"): the explorer of V1_ reads V2_'s
// pose and trajectory and refuses a trajectory that comes nearer than min_separation_m to it, in
// space and time; where the two are already nearer, only a trajectory that comes nearer still.
TEST_F(ExplorerNodeTest, RefusesTrajectoriesThatComeTooNearAnotherVehicle) {
  config_.vehicle_prefix = "V1_";
  config_.explorer.peers = {"V2_"};
  config_.explorer.min_separation_m = 1.2;
  ExplorerNode node(lcm_, config_, clock_);
  const double t0 = UtimeToSeconds(clock_.NowUtime());
  const PiecewisePolynomialTrajectory through = Straight({-1, 0, 1}, {2, 0, 1}, t0, 3.0);
  const PiecewisePolynomialTrajectory beside = Straight({-1, -1.5, 1}, {2, -1.5, 1}, t0, 3.0);
  EXPECT_EQ(node.explorer().SeparationRefusal(through), "") << "nothing known of V2_ yet";
  pose_t pose{};
  pose.utime = clock_.NowUtime();
  pose.valid = true;
  pose.position_m[0] = 1.0;
  pose.position_m[2] = 1.0;
  pose.orientation_wxyz[0] = 1.0;
  lcm_.publish("V2_POSE_VICON", &pose);
  lcm_.publish("POSE_VICON", &pose);  // no vehicle's: V1_'s is V1_POSE_VICON
  Dispatch();
  const std::string refusal = node.explorer().SeparationRefusal(through);
  EXPECT_NE(refusal.find("V2_"), std::string::npos) << refusal;
  EXPECT_NE(refusal.find("0.00 m"), std::string::npos) << refusal;
  EXPECT_EQ(node.explorer().SeparationRefusal(beside), "");
  // V2_ leaves along y before V1_ gets there: the same line keeps 2 m (at the start).
  const trajectory_t away = ToMessage(Straight({1, 0, 1}, {1, 3, 1}, t0, 1.0), 0, 1, 5);
  lcm_.publish("V2_TRAJECTORY", &away);
  Dispatch();
  EXPECT_EQ(node.explorer().SeparationRefusal(through), "");
  // ...but not from where V2_ holds at its end.
  EXPECT_NE(node.explorer().SeparationRefusal(Straight({-1, 3, 1}, {2, 3, 1}, t0 + 5.0, 3.0)), "");
  // Already 0.5 m apart: moving away is allowed, nearer is not.
  const trajectory_t hold = ToMessage(Straight({1, 0, 1}, {1, 0, 1}, t0, 1.0), 0, 2, 5);
  lcm_.publish("V2_TRAJECTORY", &hold);
  Dispatch();
  EXPECT_EQ(node.explorer().SeparationRefusal(Straight({1, 0.5, 1}, {1, 3, 1}, t0, 3.0)), "");
  EXPECT_NE(node.explorer().SeparationRefusal(Straight({1, 0.5, 1}, {1, 0.2, 1}, t0, 3.0)), "");
  // A malformed trajectory from V2_ is counted and changes nothing.
  trajectory_t bad = hold;
  bad.durations_s[0] = -1.0;
  lcm_.publish("V2_TRAJECTORY", &bad);
  Dispatch();
  EXPECT_EQ(node.drops().count("malformed"), 1);
  EXPECT_NE(node.explorer().SeparationRefusal(Straight({1, 0.5, 1}, {1, 0.2, 1}, t0, 3.0)), "");
}

TEST(ExplorerConfig, ReadsTheVehiclesAndRefusesBadOnes) {
  const ExplorerNodeConfig c = LoadExplorerNodeConfig(ConfigNode::FromString(
      "explorer: {vehicle_prefix: V2_, peers: [{prefix: V1_}, {prefix: V3_}], "
      "min_separation_m: 1.5, max_yield_s: 30}",
      "test"));
  EXPECT_EQ(c.vehicle_prefix, "V2_");
  EXPECT_EQ(c.explorer.peers, (std::vector<std::string>{"V1_", "V3_"}));
  EXPECT_EQ(c.explorer.min_separation_m, 1.5);
  EXPECT_EQ(c.explorer.max_yield_s, 30.0);
  for (const char* bad :
       {"explorer: {vehicle_prefix: V1_, peers: [{prefix: V1_}]}",
        "explorer: {peers: [{prefix: V2_}, {prefix: V2_}]}", "explorer: {min_separation_m: 0}"}) {
    EXPECT_THROW(LoadExplorerNodeConfig(ConfigNode::FromString(bad, "test")), ConfigError) << bad;
  }
}

}  // namespace
}  // namespace kestrel

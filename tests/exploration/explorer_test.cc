// The Explorer without LCM, as tests/control/safety_test.cc tests the controller's supervisor:
// every transition of WAITING -> STARTUP -> EXPLORING -> RETURNING -> DONE, the restarts, the
// yields, and every state with inputs out of order. A vehicle that flies every trajectory it is
// given exactly, over a small hand-made room.
#include "exploration/explorer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "tests/exploration/test_input.h"

namespace kestrel {
namespace {

constexpr int64_t kEpoch = 4242;
constexpr double kStep = 0.05;  // the node's step period, s
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// A room x, y in [-2, 2) m, z in [-0.15, 1.55) m at 0.1 m: walls two cells thick, the floor below
// z = 0; cells within known_radius_m of the origin observed (free 1e-4, walls and floor 0.9999),
// the rest unknown (P_init 0.1).
std::vector<float> Room(double known_radius_m) {
  return test::FillGrid(Eigen::Vector3i(40, 40, 17), Eigen::Vector3d(-2.0, -2.0, -0.15), 0.1, 0.1f,
                        [&](double x, double y, double z, float* p) {
                          if (std::hypot(x, y) > known_radius_m) return;
                          const bool wall = std::abs(x) > 1.8 || std::abs(y) > 1.8 || z < 0.0;
                          *p = wall ? 0.9999f : 1e-4f;
                        });
}

template <typename T>
std::vector<T> Of(const std::vector<ExplorerAction>& actions) {
  std::vector<T> out;
  for (const ExplorerAction& a : actions) {
    if (const T* x = std::get_if<T>(&a)) out.push_back(*x);
  }
  return out;
}

// Given an explorer over Room(known_radius_m) and a vehicle hovering at (0, 0, h): the controller
// flies each trajectory at once (TRACK, its seq, our epoch) and exactly, holds at its end, and
// lands when told to.
class ExplorerTest : public ::testing::Test {
 public:  // the out-of-order inputs below reach into it
  ExplorerTest() {
    config_.map.min_m = Eigen::Vector3d(-2.0, -2.0, -0.15);
    config_.map.max_m = Eigen::Vector3d(2.0, 2.0, 1.55);
    config_.map.resolution_m = 0.1;
    SetRoom(1.2);
    pose_.p = Eigen::Vector3d(0.0, 0.0, config_.planner.projection.height_m);
    report_.mode = ControllerMode::kHold;
  }
  void SetRoom(double known_radius_m) {
    cells_ = Room(known_radius_m);
    map_.view = test::GridView(Eigen::Vector3i(40, 40, 17), Eigen::Vector3d(-2.0, -2.0, -0.15), 0.1,
                               cells_);
    map_.current = true;
    ++map_.seq;
  }
  Explorer& Make() {
    explorer_ = std::make_unique<Explorer>(config_, kEpoch);
    return *explorer_;
  }
  // A new explorer (config_) and the vehicle back at the start, hovering at h.
  Explorer& Restart() {
    t_ = 100.0;
    flying_.reset();
    accept_ = true;
    report_ = ControllerReport{};
    report_.mode = ControllerMode::kHold;
    pose_ = Pose3{};
    pose_.p.z() = config_.planner.projection.height_m;
    all_.clear();
    return Make();
  }
  // The inputs of one step (pose, controller) and the step; the controller follows the actions.
  std::vector<ExplorerAction> Step() {
    if (flying_) {
      const FlatOutput f = flying_->Evaluate(t_);
      pose_.p = f.position_m;
      pose_.q = QuaternionFromYaw(f.yaw_rad);
      if (t_ > flying_->end_time_s() && report_.mode == ControllerMode::kTrack) {
        report_.mode = ControllerMode::kHold;
      }
    }
    explorer_->OnPose(t_, pose_);
    explorer_->OnControllerReport(report_);
    std::vector<ExplorerAction> actions = explorer_->Step(t_, map_);
    for (const ExplorerAction& a : actions) {
      if (const auto* p = std::get_if<PublishTrajectory>(&a)) {
        if (accept_) {
          flying_ = p->trajectory;
          report_.mode = ControllerMode::kTrack;
          report_.trajectory_seq = p->seq;
          report_.trajectory_epoch = kEpoch;
        }
      } else if (std::holds_alternative<SendLand>(a)) {
        report_.mode = ControllerMode::kLand;
        flying_.reset();
      }
    }
    all_.insert(all_.end(), actions.begin(), actions.end());
    return actions;
  }
  // Steps every kStep until `until` holds (true) or max_s simulated seconds have passed.
  template <typename F>
  bool RunUntil(F until, double max_s) {
    for (const double end = t_ + max_s; t_ < end;) {
      t_ += kStep;
      Step();
      if (until()) return true;
    }
    return false;
  }
  bool RunToState(ExplorerState state, double max_s = 60.0) {
    return RunUntil([&] { return explorer_->state() == state; }, max_s);
  }
  // The statuses since the last call.
  std::vector<PublishStatus> TakeStatuses() {
    std::vector<PublishStatus> s = Of<PublishStatus>(all_);
    all_.clear();
    return s;
  }

  ExplorerConfig config_;
  std::vector<float> cells_;
  ExplorerMap map_;
  std::unique_ptr<Explorer> explorer_;
  double t_{100.0};
  Pose3 pose_;
  ControllerReport report_;
  std::optional<PiecewisePolynomialTrajectory> flying_;
  bool accept_{true};  // the controller takes trajectories
  std::vector<ExplorerAction> all_;
};

// The names: one table, every value named, names read back.
TEST(ExplorerNames, OneTableForStatesReasonsAndEvents) {
  const char* names[] = {"waiting", "startup", "exploring", "returning", "done", "failed"};
  for (int v = 0; v < kExplorerStateCount; ++v) {
    const ExplorerState s = static_cast<ExplorerState>(v);
    EXPECT_STREQ(ToString(s), names[v]);
    EXPECT_EQ(ExplorerStateFromName(names[v]), s);
    EXPECT_EQ(ExplorerStateFromValue(v), s);
    EXPECT_EQ(ExplorerStateName(v), names[v]);
  }
  EXPECT_EQ(ExplorerStateFromName("STARTUP"), std::nullopt);
  EXPECT_EQ(ExplorerStateFromValue(6), std::nullopt);
  EXPECT_EQ(ExplorerStateName(-1), "state -1");
  EXPECT_STREQ(ToString(static_cast<ExplorerState>(9)), "unknown");
  EXPECT_STREQ(ToString(ReplanReason::kReplanPeriod), "replan period");
  EXPECT_STREQ(ToString(ReplanReason::kStartupDone), "start-up turn done");
  for (int e = 0; e < kExplorerEventCount; ++e) {
    EXPECT_STRNE(ToString(static_cast<ExplorerEvent>(e)), "unknown") << e;
  }
}

// WAITING needs a current map, a pose and the controller hovering at h; any of them missing or
// coming in another order, it waits and publishes nothing. Then one start-up trajectory from
// where the vehicle is, numbered 1: STARTUP.
TEST_F(ExplorerTest, WaitsForMapPoseAndControllerInAnyOrder) {
  Explorer& e = Make();
  ExplorerMap not_current = map_;
  not_current.current = false;
  EXPECT_TRUE(e.Step(t_, map_).empty()) << "no pose, no controller";
  EXPECT_TRUE(e.OnPose(t_, pose_));
  EXPECT_TRUE(e.Step(t_, map_).empty()) << "no controller";
  report_.mode = ControllerMode::kTakeoff;
  e.OnControllerReport(report_);
  EXPECT_TRUE(e.Step(t_, map_).empty()) << "taking off (startup_while_climbing off)";
  report_.mode = ControllerMode::kHold;
  e.OnControllerReport(report_);
  EXPECT_TRUE(e.Step(t_, not_current).empty()) << "the map is not current";
  pose_.p.z() = 0.3;
  e.OnPose(t_, pose_);
  EXPECT_TRUE(e.Step(t_, map_).empty()) << "below h - height_tolerance_m";
  EXPECT_EQ(e.state(), ExplorerState::kWaiting);
  pose_.p.z() = config_.planner.projection.height_m;
  e.OnPose(t_, pose_);
  const std::vector<ExplorerAction> a = e.Step(t_, map_);
  EXPECT_EQ(e.state(), ExplorerState::kStartup);
  const std::vector<PublishTrajectory> t = Of<PublishTrajectory>(a);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].seq, 1);
  EXPECT_EQ(t[0].trajectory.start_time_s(), t_);
  EXPECT_LT((t[0].trajectory.Evaluate(t_).position_m - pose_.p).norm(), 1e-9);
  // A full circle of the heading, and no status: no plan yet.
  EXPECT_NEAR(t[0].trajectory.Evaluate(t[0].trajectory.end_time_s()).yaw_rad, 2.0 * M_PI, 1e-9);
  EXPECT_TRUE(Of<PublishStatus>(a).empty());
  EXPECT_EQ(e.Record().home_xy_m, Eigen::Vector2d(0.0, 0.0));
}

// With startup_while_climbing, the turn starts in TAKEOFF once the vehicle has risen
// startup_min_rise_m above the lowest height seen while waiting.
TEST_F(ExplorerTest, StartsWhileClimbingOnceRisen) {
  config_.startup_while_climbing = true;
  Explorer& e = Make();
  report_.mode = ControllerMode::kTakeoff;
  pose_.p.z() = 0.05;
  e.OnControllerReport(report_);
  e.OnPose(t_, pose_);
  EXPECT_TRUE(e.Step(t_, map_).empty());
  pose_.p.z() = 0.05 + config_.startup_min_rise_m - 0.01;
  e.OnPose(t_ + 0.5, pose_);
  EXPECT_TRUE(e.Step(t_ + 0.5, map_).empty()) << "not risen enough";
  pose_.p.z() = 0.05 + config_.startup_min_rise_m;
  e.OnPose(t_ + 0.6, pose_);
  EXPECT_EQ(Of<PublishTrajectory>(e.Step(t_ + 0.6, map_)).size(), 1u);
  EXPECT_EQ(e.state(), ExplorerState::kStartup);
  EXPECT_EQ(e.Record().lowest_z_m, 0.05);
}

// STARTUP -> EXPLORING: the controller flies the turn; half a second after its end the first
// plan goes out (a trajectory and a status "start-up turn done" in EXPLORING).
TEST_F(ExplorerTest, FlownStartupTurnLeadsToTheFirstPlan) {
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kStartup, 1.0));
  const double turn_end = flying_->end_time_s();
  TakeStatuses();
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  EXPECT_GT(t_, turn_end + 0.5 - 1e-9);
  EXPECT_LT(t_, turn_end + 0.5 + kStep + 1e-9);
  const std::vector<PublishStatus> s = TakeStatuses();
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].reason, "start-up turn done");
  EXPECT_EQ(s[0].state, ExplorerState::kExploring);
  EXPECT_EQ(s[0].seq, 1);
  EXPECT_TRUE(s[0].replan);
  EXPECT_EQ(s[0].plan->status, PlanStatus::kGoal) << s[0].plan->reason;
  EXPECT_EQ(explorer_->plans(), 1);
  EXPECT_EQ(explorer_->last_plan(), s[0].plan);
  EXPECT_EQ(report_.trajectory_seq, 2) << "the first plan's trajectory was flown";
}

// A controller that reports another explorer's trajectory with our number (a status from
// another run: its epoch is not ours) is not flying our turn: back to WAITING after 1 s, counted,
// and a new turn retry_period_s later.
TEST_F(ExplorerTest, StartupNotFlownGoesBackToWaitingAndRetries) {
  Make();
  accept_ = false;
  ASSERT_TRUE(RunToState(ExplorerState::kStartup, 1.0));
  const double sent = t_;
  report_.mode = ControllerMode::kTrack;
  report_.trajectory_seq = 1;
  report_.trajectory_epoch = kEpoch + 1;
  ASSERT_TRUE(RunToState(ExplorerState::kWaiting, 2.0));
  EXPECT_GT(t_, sent + 1.0);
  EXPECT_EQ(explorer_->count(ExplorerEvent::kStartupNotFlown), 1);
  ASSERT_EQ(Of<ReportEvent>(all_).size(), 1u);
  // The retry: HOLD at h again, after retry_period_s.
  report_.mode = ControllerMode::kHold;
  const double back = t_;
  all_.clear();
  ASSERT_TRUE(RunToState(ExplorerState::kStartup, 3.0));
  EXPECT_GE(t_, back + config_.retry_period_s - 1e-9);
  const std::vector<PublishTrajectory> t = Of<PublishTrajectory>(all_);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(t[0].seq, 2);
}

// EXPLORING replans when the trajectory ends and every replan_period_s while it is flown; the
// reasons say which, and the goal being flown to is handed back to the planner.
TEST_F(ExplorerTest, ReplansOnPeriodAndAtTheEnd) {
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  TakeStatuses();
  ASSERT_TRUE(flying_.has_value());
  const double end = flying_->end_time_s();
  ASSERT_GT(end - t_, 1.5) << "the first goal is more than a replan period away";
  RunUntil([] { return false; }, 1.0);
  std::vector<PublishStatus> s = TakeStatuses();
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].reason, "replan period");
  // Without periodic replans the trajectory runs out: "trajectory ended".
  config_.replan_period_s = 1e6;
  Restart();
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  TakeStatuses();
  const double first_end = flying_->end_time_s();
  ASSERT_TRUE(RunUntil([&] { return !Of<PublishStatus>(all_).empty(); }, 30.0));
  s = TakeStatuses();
  EXPECT_EQ(s[0].reason.rfind("trajectory ended", 0), 0u) << s[0].reason;
  EXPECT_GE(t_, first_end - 1e-9);
}

// A trajectory the controller refuses (it keeps holding on the last one it took): after
// controller_hold_replan_s the explorer replans from the flown state, counted.
TEST_F(ExplorerTest, RefusedTrajectoryIsReplannedFromTheFlownState) {
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  // The first plan's trajectory is refused: the controller holds where it is, on seq 1.
  report_.mode = ControllerMode::kHold;
  report_.trajectory_seq = 1;
  flying_.reset();
  accept_ = false;
  TakeStatuses();
  const double refused_at = t_;
  ASSERT_TRUE(RunUntil([&] { return explorer_->count(ExplorerEvent::kControllerHolds) > 0; }, 2.0));
  EXPECT_GE(t_, refused_at + config_.controller_hold_replan_s - 1e-9);
  const std::vector<PublishStatus> s = TakeStatuses();
  ASSERT_FALSE(s.empty());
  EXPECT_EQ(s.back().reason, "the controller holds");
  EXPECT_EQ(explorer_->state(), ExplorerState::kExploring);
}

// An explored room: the gain rule ends exploration at the first plan; RETURNING flies home, and
// half a second after the flight home the land command goes out with a status in DONE.
TEST_F(ExplorerTest, GainRuleEndsThenHomeThenLand) {
  SetRoom(10.0);
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kReturning, 30.0));
  std::vector<PublishStatus> s = TakeStatuses();
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].plan->status, PlanStatus::kExplorationDone);
  EXPECT_EQ(s[0].state, ExplorerState::kReturning);
  EXPECT_EQ(s[1].reason, "exploration ended (gain rule): flying home");
  EXPECT_FALSE(s[1].replan);
  EXPECT_EQ(explorer_->end_rule(), "gain rule");
  ASSERT_TRUE(RunToState(ExplorerState::kDone, 30.0));
  s = TakeStatuses();
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].state, ExplorerState::kDone);
  EXPECT_EQ(s[0].reason.rfind("home: land sent (gain rule, returned home", 0), 0u) << s[0].reason;
  EXPECT_EQ(explorer_->landing().rfind("returned home", 0), 0u);
  EXPECT_EQ(report_.mode, ControllerMode::kLand) << "the land command went out";
  // DONE is final: nothing more, whatever comes.
  report_.mode = ControllerMode::kHold;
  EXPECT_FALSE(RunUntil([&] { return !all_.empty(); }, 5.0));
}

// return_home off: DONE and the land command where exploration ended; land_at_end off: DONE
// without a land command.
TEST_F(ExplorerTest, WithoutReturnHomeOrLandAtEnd) {
  SetRoom(10.0);
  config_.return_home = false;
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kDone, 30.0));
  EXPECT_EQ(Of<SendLand>(all_).size(), 1u);
  EXPECT_EQ(explorer_->landing(), "landed where exploration ended (return_home off)");
  config_.land_at_end = false;
  Restart();
  ASSERT_TRUE(RunToState(ExplorerState::kDone, 30.0));
  EXPECT_TRUE(Of<SendLand>(all_).empty());
}

// Unlearned cells (docs/exploration.md, "Unlearned cells"): the room explored but for the layer
// of cells in front of its east wall, which stay contested (P 0.3, the map does not change: what a
// partly occupied wall does with a clamp that lets cells come back). The gain keeps predicting that
// the wall can be learned, so the explorer flies for it plan after plan; with unlearned_looks the
// cells looked at that often without learning are read as certain, the gain rule ends exploration,
// and the status and the ledger say how many cells were left.
TEST_F(ExplorerTest, ContestedCellsLookedAtWithoutLearningAreNotChased) {
  const auto contested_east_wall = [&] {
    SetRoom(10.0);
    for (int k = 0; k < 17; ++k) {
      for (int j = 0; j < 40; ++j) {
        const double y = -2.0 + 0.1 * (j + 0.5), z = -0.15 + 0.1 * (k + 0.5);
        if (z > 0.0 && std::abs(y) < 1.8)
          cells_[static_cast<size_t>(37 + 40 * (j + 40 * k))] = 0.3f;
      }
    }
  };
  contested_east_wall();
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  EXPECT_FALSE(RunToState(ExplorerState::kReturning, 20.0))
      << "without the ledger the contested wall keeps its predicted gain";
  EXPECT_EQ(explorer_->unlearned().count(), 0u);
  const int64_t plans_without = explorer_->plans();
  ASSERT_GE(plans_without, 10);

  config_.unlearned_looks = 3;
  Restart();
  contested_east_wall();
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  ASSERT_TRUE(RunToState(ExplorerState::kReturning, 20.0));
  EXPECT_EQ(explorer_->end_rule(), "gain rule");
  const size_t unlearned = explorer_->unlearned().count();
  EXPECT_GT(unlearned, 50u);
  // Only contested cells are marked: every marked one lies in the east wall.
  for (int32_t i = 0; i < 40 * 40 * 17; ++i) {
    if (explorer_->unlearned().unlearned(i)) {
      ASSERT_EQ(i % 40, 37) << "cell " << i << " is not in the contested layer";
    }
  }
  const std::vector<PublishStatus> s = Of<PublishStatus>(all_);
  ASSERT_FALSE(s.empty());
  bool said = false;
  for (const PublishStatus& status : s) {
    if (status.plan->status == PlanStatus::kExplorationDone) {
      said = status.plan->unlearned_cells == static_cast<int64_t>(unlearned);
    }
  }
  EXPECT_TRUE(said) << "the ending plan carries the count";
}

// Plans that keep failing (the vehicle outside the map): max_failed_plans in a row, each counted
// and retry_period_s apart, end exploration ("planning failures"); the flights home fail too,
// and after max_home_attempts the vehicle lands where it is, saying why.
TEST_F(ExplorerTest, FailuresEndExplorationAndLandInPlace) {
  config_.max_failed_plans = 2;
  config_.max_home_attempts = 2;
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kStartup, 1.0));
  // Blown out of the room during the turn: every plan fails.
  flying_.reset();
  report_.mode = ControllerMode::kHold;
  pose_.p = Eigen::Vector3d(5.0, 5.0, config_.planner.projection.height_m);
  report_.mode = ControllerMode::kTrack;
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  ASSERT_TRUE(RunToState(ExplorerState::kDone, 10.0));
  EXPECT_EQ(explorer_->count(ExplorerEvent::kPlanFailed), 2);
  EXPECT_EQ(explorer_->end_rule(), "planning failures");
  EXPECT_EQ(explorer_->landing().rfind("landed elsewhere: no path home after 2 attempts", 0), 0u)
      << explorer_->landing();
  EXPECT_NE(explorer_->landing().find("in place"), std::string::npos) << explorer_->landing();
  const std::vector<PublishStatus> s = Of<PublishStatus>(all_);
  ASSERT_GE(s.size(), 4u);
  EXPECT_NE(s[s.size() - 2].reason.find("no path home yet"), std::string::npos);
  EXPECT_EQ(s.back().state, ExplorerState::kDone);
  EXPECT_EQ(Of<SendLand>(all_).size(), 1u);
}

// An end rule that holds while the take-off point is unreachable (here a take-off point restored
// outside the room) is deferred max_end_deferrals times, retry_period_s apart, then ends
// exploration.
TEST_F(ExplorerTest, EndRuleWithHomeUnreachableIsDeferred) {
  SetRoom(10.0);
  config_.max_end_deferrals = 2;
  ExplorerRecord record;
  record.state = ExplorerState::kExploring;
  record.home_xy_m = Eigen::Vector2d(5.0, 5.0);
  ASSERT_TRUE(Make().Restore(record));
  ASSERT_TRUE(RunToState(ExplorerState::kReturning, 10.0));
  EXPECT_EQ(explorer_->count(ExplorerEvent::kEndDeferred), 2);
  const std::vector<PublishStatus> s = Of<PublishStatus>(all_);
  ASSERT_GE(s.size(), 3u);
  EXPECT_EQ(s[0].state, ExplorerState::kExploring) << "deferred";
  EXPECT_EQ(s[1].state, ExplorerState::kExploring) << "deferred";
  EXPECT_EQ(s[2].state, ExplorerState::kReturning);
  EXPECT_EQ(explorer_->end_rule(), "gain rule");
  EXPECT_EQ(explorer_->plans(), static_cast<int64_t>(s.size()));
}

// Restarts: a record of the same run resumes once the vehicle is seen airborne, without a
// start-up turn; records of states before the start-up, or with a non-finite take-off point, are
// refused.
TEST_F(ExplorerTest, RestoredRecordResumesWhenAirborne) {
  ExplorerRecord record;
  record.home_xy_m = Eigen::Vector2d(0.2, -0.1);
  record.lowest_z_m = 0.0;
  record.state = ExplorerState::kWaiting;
  EXPECT_FALSE(Make().Restore(record));
  record.state = ExplorerState::kFailed;
  EXPECT_FALSE(explorer_->Restore(record));
  record.state = ExplorerState::kExploring;
  record.home_xy_m.x() = kNan;
  EXPECT_FALSE(explorer_->Restore(record));
  EXPECT_FALSE(explorer_->resume_pending());
  record.home_xy_m.x() = 0.2;

  // EXPLORING, the vehicle taking off: as on a first start until it is airborne; then a plan
  // from the flown state at once.
  ASSERT_TRUE(explorer_->Restore(record));
  EXPECT_TRUE(explorer_->resume_pending());
  report_.mode = ControllerMode::kTakeoff;
  Step();
  EXPECT_EQ(explorer_->state(), ExplorerState::kWaiting);
  report_.mode = ControllerMode::kHold;
  t_ += kStep;
  const std::vector<ExplorerAction> a = Step();
  EXPECT_EQ(explorer_->state(), ExplorerState::kExploring);
  EXPECT_FALSE(explorer_->resume_pending());
  const std::vector<PublishStatus> s = Of<PublishStatus>(a);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].reason, "resumed after a restart");
  EXPECT_EQ(explorer_->resume_status().rfind("resumed exploring from the flown state", 0), 0u)
      << explorer_->resume_status();
  EXPECT_EQ(explorer_->Record().home_xy_m, record.home_xy_m) << "the take-off point is kept";

  // RETURNING: plans home at once.
  record.state = ExplorerState::kReturning;
  record.end_rule = "gain rule";
  Make().Restore(record);
  all_.clear();
  Step();
  EXPECT_EQ(explorer_->state(), ExplorerState::kReturning);
  ASSERT_EQ(Of<PublishStatus>(all_).size(), 1u);
  EXPECT_EQ(Of<PublishStatus>(all_)[0].reason.rfind("resumed after a restart (gain rule)", 0), 0u);

  // DONE while the controller lands as asked before: DONE, no second land command; DONE in
  // HOLD: the land command again.
  record.state = ExplorerState::kDone;
  Make().Restore(record);
  report_.mode = ControllerMode::kLand;
  all_.clear();
  Step();
  EXPECT_EQ(explorer_->state(), ExplorerState::kDone);
  EXPECT_TRUE(Of<SendLand>(all_).empty());
  Make().Restore(record);
  report_.mode = ControllerMode::kHold;
  all_.clear();
  Step();
  EXPECT_EQ(explorer_->state(), ExplorerState::kDone);
  EXPECT_EQ(Of<SendLand>(all_).size(), 1u);
}

// Goal and flown-path memory: while waiting only the lowest height; once flying, the flown
// corridor every flown_path_spacing_m and a view at every kFlownViewYawStepRad of turn; a goal
// passed within 0.3 m (non-stop flight) or whose trajectory ended is remembered with the view
// the vehicle had there, once.
TEST_F(ExplorerTest, RemembersTheFlownPathAndTheReachedGoals) {
  Explorer& e = Make();
  pose_.p.z() = 0.2;
  e.OnPose(t_, pose_);
  pose_.p.z() = config_.planner.projection.height_m;
  e.OnPose(t_, pose_);
  EXPECT_TRUE(e.Input().flown_path.empty()) << "nothing is flown while waiting";
  EXPECT_EQ(e.Record().lowest_z_m, 0.2);
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 30.0));
  const PlannerInput turn = e.Input();
  EXPECT_EQ(turn.flown_path.size(), 1u) << "the turn is flown in place";
  // A full circle in place: a view each time the heading has turned kFlownViewYawStepRad.
  EXPECT_GE(turn.flown_views.size(), 20u);
  for (size_t i = 1; i < turn.flown_views.size(); ++i) {
    EXPECT_GE(
        std::abs(std::remainder(turn.flown_views[i].z() - turn.flown_views[i - 1].z(), 2.0 * M_PI)),
        kFlownViewYawStepRad - 1e-12);
  }
  EXPECT_EQ(e.Record().lowest_z_m, 0.2) << "not lowered once flying";
  ASSERT_TRUE(e.last_plan() && e.last_plan()->chosen >= 0);
  const Candidate goal = e.last_plan()->candidates[static_cast<size_t>(e.last_plan()->chosen)];
  ASSERT_TRUE(e.Input().current_goal.has_value()) << "the goal being flown to";
  EXPECT_EQ(e.Input().current_goal->head<2>(), goal.position_m);
  EXPECT_TRUE(e.Input().reached_goals.empty());
  ASSERT_TRUE(RunUntil([&] { return !e.Input().reached_goals.empty(); }, 30.0));
  const PlannerInput in = e.Input();
  EXPECT_LT((pose_.p.head<2>() - in.reached_goals[0].head<2>()).norm(), 0.3 + 1e-9);
  ASSERT_EQ(in.reached_views.size(), in.reached_goals.size());
  for (size_t i = 1; i < in.flown_path.size(); ++i) {
    EXPECT_GE((in.flown_path[i] - in.flown_path[i - 1]).norm(),
              config_.flown_path_spacing_m - 1e-12);
  }
  EXPECT_GT(in.flown_path.size(), 1u);
  EXPECT_EQ(in.startup_center_m, Eigen::Vector2d(0.0, 0.0));
}

// Another vehicle seen long ago and silent since stays where it was seen: a trajectory through
// that place is refused, one away from it is not. A pose older than the one held is ignored, and
// so are peers the explorer does not know and non-finite positions.
TEST_F(ExplorerTest, AStalePeerStaysWhereItWasSeen) {
  config_.peers = {"V2_"};
  Explorer& e = Make();
  const double h = config_.planner.projection.height_m;
  EXPECT_TRUE(e.OnPeerPose(0, 1.0, Eigen::Vector3d(0.0, 1.0, h)));
  EXPECT_FALSE(e.OnPeerPose(0, 0.5, Eigen::Vector3d(0.0, -1.0, h))) << "older";
  EXPECT_FALSE(e.OnPeerPose(1, 2.0, Eigen::Vector3d(0.0, -1.0, h))) << "no such peer";
  EXPECT_FALSE(e.OnPeerPose(0, 2.0, Eigen::Vector3d(kNan, -1.0, h)));
  const auto line = [&](double y1) {
    PolynomialSegment s;
    s.duration_s = 2.0;
    s.coefficients = {std::vector<double>{0.0}, {0.0, y1 / 2.0}, {h}, {0.0}};
    return *PiecewisePolynomialTrajectory::Create(t_, {s}, nullptr);
  };
  const std::string refusal = e.SeparationRefusal(line(1.5));
  EXPECT_NE(refusal.find("V2_"), std::string::npos) << refusal;
  EXPECT_EQ(e.SeparationRefusal(line(-1.5)), "");
  EXPECT_EQ(e.Input().peer_goals.size(), 0u) << "no trajectory: no goal";
}

// Another vehicle, far now, that will come to hold where this one starts, with a separation
// larger than the room: every trajectory is refused (this vehicle would hold at its goal too near
// it), and the vehicle yields (counted, not a failed plan, the state kept) for max_yield_s; after
// that each refused plan is a failure.
TEST_F(ExplorerTest, YieldsToAnotherVehicleThenCountsFailures) {
  config_.peers = {"V2_"};
  config_.min_separation_m = 3.0;
  config_.max_yield_s = 2.0;
  config_.max_failed_plans = 100;
  Make();
  ASSERT_TRUE(RunToState(ExplorerState::kStartup, 1.0));
  const double h = config_.planner.projection.height_m;
  ASSERT_TRUE(RunUntil([&] { return t_ > flying_->end_time_s(); }, 30.0));
  PolynomialSegment s;
  s.duration_s = 100.0;
  s.coefficients = {std::vector<double>{30.0, -0.3}, {0.0}, {h}, {0.0}};
  ASSERT_TRUE(
      explorer_->OnPeerTrajectory(0, *PiecewisePolynomialTrajectory::Create(t_, {s}, nullptr)));
  EXPECT_FALSE(
      explorer_->OnPeerTrajectory(3, *PiecewisePolynomialTrajectory::Create(t_, {s}, nullptr)));
  ASSERT_TRUE(RunToState(ExplorerState::kExploring, 2.0));
  EXPECT_EQ(explorer_->count(ExplorerEvent::kYielded), 1);
  EXPECT_EQ(explorer_->count(ExplorerEvent::kPlanFailed), 0);
  ASSERT_TRUE(RunUntil([&] { return explorer_->count(ExplorerEvent::kPlanFailed) > 0; }, 5.0));
  EXPECT_GE(explorer_->count(ExplorerEvent::kYielded), 2);
  EXPECT_EQ(explorer_->state(), ExplorerState::kExploring);
  const std::vector<PublishStatus> st = Of<PublishStatus>(all_);
  ASSERT_FALSE(st.empty());
  EXPECT_NE(st.back().plan->reason.find("refused by the separation check"), std::string::npos)
      << st.back().plan->reason;
}

// Every state with every input out of order (a map not current, a controller report naming
// another explorer's trajectory, a trajectory the controller refused, a peer's stale pose, a
// non-finite pose, a step at a non-finite time): each leaves the explorer in a named state, the
// same or one a decision explains (a status or an event in the actions), never a crash.
TEST_F(ExplorerTest, EveryStateWithEveryInputOutOfOrder) {
  struct Input {
    const char* name;
    std::function<void(ExplorerTest*)> apply;
  };
  const std::vector<Input> inputs{
      {"map not current", [](ExplorerTest* f) { f->map_.current = false; }},
      {"another run's controller report",
       [](ExplorerTest* f) {
         f->report_.mode = ControllerMode::kTrack;
         f->report_.trajectory_epoch = kEpoch + 7;
         f->accept_ = false;
       }},
      {"a refused trajectory",
       [](ExplorerTest* f) {
         f->report_.mode = ControllerMode::kHold;
         f->report_.trajectory_seq = 0;
         f->flying_.reset();
         f->accept_ = false;
       }},
      {"a stale peer pose",
       [](ExplorerTest* f) {
         f->explorer_->OnPeerPose(0, f->t_, Eigen::Vector3d(1.0, 1.0, 0.75));
         EXPECT_FALSE(f->explorer_->OnPeerPose(0, f->t_ - 50.0, Eigen::Vector3d(0, 0, 0.75)));
       }},
      {"a non-finite pose",
       [](ExplorerTest* f) {
         Pose3 bad = f->pose_;
         bad.p.x() = kNan;
         EXPECT_FALSE(f->explorer_->OnPose(f->t_, bad));
       }},
      {"a non-finite time",
       [](ExplorerTest* f) {
         EXPECT_TRUE(f->explorer_->Step(kNan, f->map_).empty());
         EXPECT_FALSE(f->explorer_->OnPose(kNan, f->pose_));
       }},
  };
  const ExplorerState states[] = {ExplorerState::kWaiting, ExplorerState::kStartup,
                                  ExplorerState::kExploring, ExplorerState::kReturning,
                                  ExplorerState::kDone};
  for (const ExplorerState state : states) {
    for (const Input& input : inputs) {
      SCOPED_TRACE(std::string(ToString(state)) + ", " + input.name);
      // A fresh flight to `state` (an explored room ends at the first plan).
      SetRoom(state == ExplorerState::kExploring ? 1.2 : 10.0);
      config_.peers = {"V2_"};
      Restart();
      if (state != ExplorerState::kWaiting) {
        ASSERT_TRUE(RunToState(state, 60.0));
      }
      all_.clear();
      input.apply(this);
      for (int i = 0; i < 30; ++i) {  // 1.5 s
        const ExplorerState before = explorer_->state();
        t_ += kStep;
        const std::vector<ExplorerAction> a = Step();
        const ExplorerState after = explorer_->state();
        ASSERT_STRNE(ToString(after), "unknown");
        if (after != before) {
          EXPECT_FALSE(Of<PublishStatus>(a).empty() && Of<ReportEvent>(a).empty() &&
                       Of<PublishTrajectory>(a).empty())
              << ToString(before) << " -> " << ToString(after) << " unexplained";
        }
      }
      // Names its state in the record a restart would read.
      EXPECT_STRNE(ToString(explorer_->Record().state), "unknown");
    }
  }
}

// What a replan that has a trajectory becomes (docs/exploration.md, "Non-stop flight"): flown
// when it starts from the flown state or nothing is flown; otherwise the flown trajectory is kept
// when this is the periodic replan and its path is clear, and the vehicle stops when not.
TEST(ExplorerReplan, NeverStepsTheSetPointInFlight) {
  for (const bool periodic : {false, true}) {
    for (const bool clear : {false, true}) {
      EXPECT_EQ(ChooseReplanUse(true, true, periodic, clear), ReplanUse::kPublish);
      EXPECT_EQ(ChooseReplanUse(true, false, periodic, clear), ReplanUse::kPublish);
      EXPECT_EQ(ChooseReplanUse(false, false, periodic, clear), ReplanUse::kPublish);
    }
  }
  EXPECT_EQ(ChooseReplanUse(false, true, true, true), ReplanUse::kKeep);
  EXPECT_EQ(ChooseReplanUse(false, true, true, false), ReplanUse::kStop);
  EXPECT_EQ(ChooseReplanUse(false, true, false, true), ReplanUse::kStop);
  EXPECT_EQ(ChooseReplanUse(false, true, false, false), ReplanUse::kStop);
}

// The progress-stall rule ends the paper's modes and the baseline; the volumetric mode only when
// asked (its own end rule terminates); a zero window disables it everywhere.
TEST(ExplorerConfig, StallRuleAppliesToModesThatNeedIt) {
  ExplorerConfig c;
  EXPECT_TRUE(StallRuleApplies(ExplorationMode::kCombined, c));
  EXPECT_TRUE(StallRuleApplies(ExplorationMode::kTwoMap, c));
  EXPECT_TRUE(StallRuleApplies(ExplorationMode::kFrontier, c));
  EXPECT_FALSE(StallRuleApplies(ExplorationMode::kVolumetric, c));
  c.end_stall_in_volumetric = true;
  EXPECT_TRUE(StallRuleApplies(ExplorationMode::kVolumetric, c));
  c.end_stall_window_s = 0.0;
  for (const ExplorationMode m : {ExplorationMode::kCombined, ExplorationMode::kTwoMap,
                                  ExplorationMode::kFrontier, ExplorationMode::kVolumetric}) {
    EXPECT_FALSE(StallRuleApplies(m, c));
  }
}

}  // namespace
}  // namespace kestrel

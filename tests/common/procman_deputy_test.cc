// The process-sheet runner with real child processes: start, stop with escalation, respawn
// with back-off, output capture, orders over LCM and scripts.
#include "common/procman/deputy.h"

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/identity.h"

namespace kestrel::procman {
namespace {

class DeputyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char dir[] = "/tmp/kestrel-deputy-test-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    config_.host = "here";
    config_.log_dir = dir;
    config_.respawn_backoff_min_s = 0.05;
    config_.respawn_backoff_max_s = 0.2;
    config_.stable_run_s = 5;
  }

  std::unique_ptr<Deputy> Make(const std::string& sheet_text) {
    return std::make_unique<Deputy>(lcm_, ParseSheet(sheet_text, "t.procman"), config_, clock_);
  }

  /// Polls until `done` or `timeout_s` of real time passed; returns done().
  static bool PollUntil(Deputy& d, const std::function<bool()>& done, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() +
                     std::chrono::milliseconds(static_cast<int>(timeout_s * 1000));
    while (std::chrono::steady_clock::now() < end) {
      d.Poll();
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return done();
  }

  lcm::LCM lcm_{"memq://"};
  WallClock clock_;
  DeputyConfig config_;
};

TEST_F(DeputyTest, StartsOnlyItsHostsCommandsAndStopsWithTheirSignal) {
  auto d = Make(R"(cmd "sleeper" { exec = "sleep 30"; host = "here"; }
                   cmd "elsewhere" { exec = "sleep 30"; host = "there"; })");
  d->Order(procman_order_t::ACTION_START, true, "");
  const CommandState* s = d->state("sleeper");
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(d->state("elsewhere"), nullptr) << "another host's command is not ours";
  EXPECT_EQ(s->state, procman_command_t::STATE_RUNNING);
  const int pid = s->pid;
  ASSERT_GT(pid, 0);
  EXPECT_EQ(kill(pid, 0), 0) << "the child exists";
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
  EXPECT_EQ(s->state, procman_command_t::STATE_STOPPED);
  EXPECT_EQ(s->exit_code, -SIGINT) << "procman's default stop signal is SIGINT";
  EXPECT_NE(kill(pid, 0), 0) << "the child is gone";
}

TEST_F(DeputyTest, EscalatesToSigkillAfterStopTimeAllowed) {
  auto d = Make(R"(cmd "stubborn" { exec = "trap '' INT; while true; do sleep 0.05; done";
                                    host = "here"; stop_time_allowed = 1; })");
  d->Order(procman_order_t::ACTION_START, false, "stubborn");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the trap install
  const auto t0 = std::chrono::steady_clock::now();
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
  const double took_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(d->state("stubborn")->exit_code, -SIGKILL);
  EXPECT_GE(took_s, 0.9) << "SIGKILL only after stop_time_allowed";
}

TEST_F(DeputyTest, RespawnsWithBackoffOnlyWhenAutoRespawn) {
  auto d = Make(R"(cmd "crasher" { exec = "exit 3"; host = "here"; auto_respawn = "true"; }
                   cmd "once" { exec = "exit 5"; host = "here"; })");
  d->Order(procman_order_t::ACTION_START, true, "");
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->state("crasher")->restarts >= 3; }, 5.0));
  EXPECT_EQ(d->state("crasher")->exit_code, 3);
  EXPECT_GE(d->state("crasher")->consecutive_quick_exits, 3) << "quick exits grow the back-off";
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->state("once")->state == procman_command_t::STATE_EXITED; }, 5.0));
  EXPECT_EQ(d->state("once")->exit_code, 5);
  EXPECT_EQ(d->state("once")->restarts, 0);
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
  const int restarts = d->state("crasher")->restarts;
  PollUntil(
      *d, [] { return false; }, 0.5);
  EXPECT_EQ(d->state("crasher")->restarts, restarts) << "a stopped command is not respawned";
}

// Every start and respawn of a command sees the runner's $KESTREL_RUN_ID (kestrel-procman sets
// it once, EnsureRunIdInEnvironment): a mapper respawned within a run resumes its checkpoint
// (docs/design.md §3.5).
TEST_F(DeputyTest, RespawnsSeeTheSameRunId) {
  ASSERT_EQ(unsetenv(kestrel::kRunIdEnvironmentVariable), 0);
  const std::string run_id = kestrel::EnsureRunIdInEnvironment();
  auto d = Make(R"(cmd "r" { exec = "echo run=$KESTREL_RUN_ID; exit 1"; host = "here";
                              auto_respawn = "true"; })");
  d->Order(procman_order_t::ACTION_START, false, "r");
  const std::string log_path = config_.log_dir + "/r.log";
  auto lines = [&] {
    std::ifstream log(log_path);
    std::vector<std::string> out;
    for (std::string line; std::getline(log, line);) out.push_back(line);
    return out;
  };
  EXPECT_TRUE(PollUntil(
      *d, [&] { return lines().size() >= 3; }, 5.0))
      << "the first start and two respawns";
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
  unsetenv(kestrel::kRunIdEnvironmentVariable);
  EXPECT_GE(d->state("r")->restarts, 2);
  for (const std::string& line : lines()) EXPECT_EQ(line, "run=" + run_id);
}

TEST_F(DeputyTest, CapturesOutputInPerCommandLogs) {
  auto d =
      Make(R"(cmd "talker" { exec = "echo hello-from-talker; echo oops >&2"; host = "here"; })");
  d->Order(procman_order_t::ACTION_START, false, "talker");
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
  std::ifstream log(config_.log_dir + "/talker.log");
  std::stringstream text;
  text << log.rdbuf();
  EXPECT_NE(text.str().find("hello-from-talker"), std::string::npos);
  EXPECT_NE(text.str().find("oops"), std::string::npos);
}

TEST_F(DeputyTest, ObeysOrdersForItsHostAndReportsStatus) {
  auto d = Make(R"(group "g" { cmd "a" { exec = "sleep 30"; host = "here"; } })");
  std::vector<procman_status_t> statuses;
  GuardedSubscriptions subs(lcm_);
  subs.Add<procman_status_t>(
      "PROCMAN_STATUS",
      [&](const std::string&, const procman_status_t& m) { statuses.push_back(m); }, nullptr);
  procman_order_t order;
  order.source = "kestrel-cmd";
  order.host = "there";  // not ours
  order.action = procman_order_t::ACTION_START;
  order.is_group = true;
  order.target = "g";
  lcm_.publish("PROCMAN_ORDERS", &order);
  d->Poll();
  EXPECT_EQ(d->state("a")->pid, 0);
  order.host = "here";
  lcm_.publish("PROCMAN_ORDERS", &order);
  d->Poll();
  EXPECT_GT(d->state("a")->pid, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the child exec (its RSS)
  d->PublishStatus();
  lcm_.handleTimeout(0);
  ASSERT_FALSE(statuses.empty());
  const procman_status_t& st = statuses.back();
  EXPECT_EQ(st.host, "here");
  EXPECT_NE(st.epoch, 0);
  EXPECT_EQ(st.epoch, d->epoch());
  ASSERT_EQ(st.num_commands, 1);
  EXPECT_EQ(st.commands[0].id, "a");
  EXPECT_EQ(st.commands[0].pid, d->state("a")->pid);
  EXPECT_EQ(st.commands[0].state, int8_t{procman_command_t::STATE_RUNNING});
  EXPECT_GT(st.commands[0].rss_mb, 0.0);
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
}

TEST_F(DeputyTest, RunsScriptsInOrderWithWaits) {
  auto d = Make(R"(cmd "first" { exec = "exit 0"; host = "here"; }
                   cmd "second" { exec = "sleep 30"; host = "here"; }
                   script "go" {
                     start cmd "first" wait "stopped";
                     wait ms 100;
                     start cmd "second" wait "running";
                     restart cmd "second";
                     stop cmd "second" wait "stopped";
                   })");
  d->RunScript("go");
  EXPECT_TRUE(d->script_running());
  ASSERT_TRUE(PollUntil(
      *d, [&] { return !d->script_running(); }, 10.0));
  EXPECT_EQ(d->state("first")->exit_code, 0);
  EXPECT_EQ(d->state("second")->state, procman_command_t::STATE_STOPPED);
  EXPECT_THROW(d->RunScript("nope"), std::invalid_argument);
}

}  // namespace
}  // namespace kestrel::procman

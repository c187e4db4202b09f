// The process-sheet runner with real child processes: start, stop with escalation, respawn
// with back-off, output capture, orders over LCM and scripts.
#include "common/procman/deputy.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "bot_procman/discovery_t.hpp"
#include "bot_procman/info2_t.hpp"
#include "bot_procman/orders2_t.hpp"
#include "bot_procman/printf_t.hpp"
#include "common/identity.h"
#include "common/procman/bot_procman.h"
#include "common/procman/sheriff.h"

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

  /// Delivers every queued message (memq: handleTimeout delivers one).
  void Drain() {
    while (lcm_.handleTimeout(0) > 0) {
    }
  }

  lcm::LCM lcm_{"memq://"};
  WallClock clock_;
  DeputyConfig config_;
};

TEST_F(DeputyTest, StartsOnlyItsHostsCommandsAndStopsWithTheirSignal) {
  auto d = Make(R"(cmd "sleeper" { exec = "sleep 30"; host = "here"; }
                   cmd "elsewhere" { exec = "sleep 30"; host = "there"; })");
  d->Order(SheriffVerb::kStart, true, "");
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
  auto d = Make(R"(cmd "stubborn" { exec = "sh -c 'trap : INT; while true; do sleep 0.05; done'";
                                    host = "here"; stop_time_allowed = 1; })");
  d->Order(SheriffVerb::kStart, false, "stubborn");
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
  auto d = Make(R"(cmd "crasher" { exec = "sh -c 'exit 3'"; host = "here"; auto_respawn = "true"; }
                   cmd "once" { exec = "sh -c 'exit 5'"; host = "here"; })");
  d->Order(SheriffVerb::kStart, true, "");
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

// A command that ran stably (a controller killed in flight) is respawned at once, not after the
// back-off that quick exits get (docs/design.md §2.5).
TEST_F(DeputyTest, RespawnsAtOnceAfterAStableRun) {
  config_.respawn_backoff_min_s = 2.0;
  config_.respawn_backoff_max_s = 4.0;
  config_.stable_run_s = 0.2;
  auto d = Make(R"(cmd "stable" { exec = "sh -c 'sleep 0.4; exit 3'"; host = "here";
                                  auto_respawn = "true"; })");
  d->Order(SheriffVerb::kStart, true, "");
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->state("stable")->exit_code == 3; }, 5.0));
  const auto exited = std::chrono::steady_clock::now();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->state("stable")->restarts >= 1; }, 5.0));
  const double gap_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - exited).count();
  EXPECT_LT(gap_s, 1.0) << "not the 2 s back-off";
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
}

// Every start and respawn of a command sees the runner's $KESTREL_RUN_ID (kestrel-procman sets
// it once, EnsureRunIdInEnvironment): a mapper respawned within a run resumes its checkpoint
// (docs/design.md §3.5).
TEST_F(DeputyTest, RespawnsSeeTheSameRunId) {
  ASSERT_EQ(unsetenv(kestrel::kRunIdEnvironmentVariable), 0);
  const std::string run_id = kestrel::EnsureRunIdInEnvironment();
  auto d = Make(R"(cmd "r" { exec = "sh -c 'echo run=$KESTREL_RUN_ID; exit 1'"; host = "here";
                              auto_respawn = "true"; })");
  d->Order(SheriffVerb::kStart, false, "r");
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
  auto d = Make(
      R"(cmd "talker" { exec = "sh -c 'echo hello-from-talker; echo oops >&2'"; host = "here"; })");
  d->Order(SheriffVerb::kStart, false, "talker");
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
  std::ifstream log(config_.log_dir + "/talker.log");
  std::stringstream text;
  text << log.rdbuf();
  EXPECT_NE(text.str().find("hello-from-talker"), std::string::npos);
  EXPECT_NE(text.str().find("oops"), std::string::npos);
}

TEST_F(DeputyTest, ReportsItsCommandsOnProcmanStatus) {
  auto d = Make(R"(group "g" { cmd "a" { exec = "sleep 30"; host = "here"; } })");
  std::vector<procman_status_t> statuses;
  GuardedSubscriptions subs(lcm_);
  subs.Add<procman_status_t>(
      "PROCMAN_STATUS",
      [&](const std::string&, const procman_status_t& m) { statuses.push_back(m); }, nullptr);
  d->Order(SheriffVerb::kStart, true, "g");
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
  auto d = Make(R"(cmd "first" { exec = "true"; host = "here"; }
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

// A script orders another host's commands as a sheriff does (orders2_t to that host's deputy),
// whatever deputy it is: here "there" knows no command at all (as libbot2's deputy at start), so
// the orders create the sheet's commands for it, "x" started and "z" stopped. Nothing is sent
// before "there" reports (its commands would be dropped); the waits read its info2_t; once its
// reports show the orders carried out, no more are sent.
TEST_F(DeputyTest, ScriptsOrderOtherHostsThroughTheirDeputies) {
  const std::string sheet = R"(cmd "x" { exec = "sleep 30"; host = "there"; stop_signal = 15; }
                               cmd "z" { exec = "sleep 30"; host = "there"; }
                               cmd "y" { exec = "sleep 30"; host = "here"; }
                               script "go" {
                                 start cmd "x" wait "running";
                                 start cmd "y" wait "running";
                                 restart cmd "x" wait "running";
                                 stop cmd "x" wait "stopped";
                               })";
  int orders_sent = 0;
  GuardedSubscriptions subs(lcm_);
  subs.Add<bot_procman::orders2_t>(
      kOrdersChannel,
      [&](const std::string&, const bot_procman::orders2_t& o) {
        if (o.host == "there") ++orders_sent;
      },
      nullptr);
  auto here = Make(sheet);
  here->RunScript("go");
  PollUntil(
      *here, [] { return false; }, 0.3);
  EXPECT_EQ(orders_sent, 0) << "no orders before the deputy of \"there\" reports";
  DeputyConfig there_config = config_;
  there_config.host = "there";
  Deputy there(lcm_, ParseSheet(R"(cmd "other" { exec = "true"; host = "elsewhere"; })", "e"),
               there_config, clock_);
  EXPECT_EQ(there.state("x"), nullptr);
  const auto both = [&](const std::function<bool()>& done) {
    return [&, done] {
      there.Poll();
      if (there.discovery_done()) there.PublishStatus();
      return done();
    };
  };
  ASSERT_TRUE(PollUntil(*here, both([&] { return !here->script_running(); }), 10.0))
      << "the script did not finish";
  ASSERT_NE(there.state("x"), nullptr) << "x created on \"there\"";
  ASSERT_NE(there.state("z"), nullptr) << "z created on \"there\"";
  EXPECT_EQ(there.state("x")->pid, 0);
  EXPECT_EQ(there.state("x")->actual_runid, 2) << "started, then restarted: a new run";
  EXPECT_TRUE(WIFSIGNALED(there.state("x")->wait_status));
  EXPECT_EQ(WTERMSIG(there.state("x")->wait_status), 15) << "stopped with its stop signal";
  EXPECT_EQ(there.state("z")->actual_runid, 0) << "created, never started";
  EXPECT_EQ(there.state("z")->command.exec, "sleep 30");
  EXPECT_EQ(there.state("x")->sheriff_id, SheetSheriffId("there", "x"));
  EXPECT_GT(here->state("y")->pid, 0);
  const int after = orders_sent;
  PollUntil(*here, both([] { return false; }), 1.5);
  EXPECT_EQ(orders_sent, after) << "no more orders once carried out";
  here->StopAll();
  ASSERT_TRUE(PollUntil(
      *here, [&] { return here->AllStopped(); }, 5.0));
}

// ---- libbot2 bot-procman's protocol (docs/protocols.md §5) ----

/// What a sheriff hears from the deputy.
struct Heard {
  explicit Heard(lcm::LCM& lcm) : subs(lcm) {
    subs.Add<bot_procman::discovery_t>(
        kDiscoverChannel,
        [this](const std::string&, const bot_procman::discovery_t& m) { discovery.push_back(m); },
        nullptr);
    subs.Add<bot_procman::info2_t>(
        kInfoChannel,
        [this](const std::string&, const bot_procman::info2_t& m) { info.push_back(m); }, nullptr);
    subs.Add<bot_procman::printf_t>(
        kPrintfChannel,
        [this](const std::string&, const bot_procman::printf_t& m) { printf.push_back(m); },
        nullptr);
  }
  [[nodiscard]] std::string Output(int32_t sheriff_id) const {
    std::string text;
    for (const auto& p : printf) {
      if (p.sheriff_id == sheriff_id) text += p.text;
    }
    return text;
  }
  GuardedSubscriptions subs;
  std::vector<bot_procman::discovery_t> discovery;
  std::vector<bot_procman::info2_t> info;
  std::vector<bot_procman::printf_t> printf;
};

const bot_procman::deputy_cmd2_t* Find(const bot_procman::info2_t& info, const std::string& name) {
  for (const auto& c : info.cmds) {
    if (c.cmd.command_name == name) return &c;
  }
  return nullptr;
}

/// The order that command `name` (its exec string `exec`) be in run `desired_runid`.
bot_procman::sheriff_cmd2_t CommandOrder(const std::string& name, const std::string& exec,
                                         int32_t desired_runid, int32_t sheriff_id) {
  bot_procman::sheriff_cmd2_t c{};
  c.cmd.exec_str = exec;
  c.cmd.command_name = name;
  c.desired_runid = desired_runid;
  c.sheriff_id = sheriff_id;
  return c;
}

/// A sheriff's orders to deputy "here" holding the one command `c`.
bot_procman::orders2_t OrdersHolding(const bot_procman::sheriff_cmd2_t& c, int64_t utime) {
  bot_procman::orders2_t orders{};
  orders.utime = utime;
  orders.host = "here";
  orders.sheriff_name = "s";
  orders.cmds = {c};
  orders.ncmds = 1;
  return orders;
}

TEST_F(DeputyTest, AnnouncesItselfThenReportsItsSheet) {
  config_.discovery_nonce = 4242;
  Heard heard(lcm_);
  auto d = Make(R"(group "drivers" { cmd "a" { exec = "$BIN/a --x=${RUN}"; host = "here";
                                               auto_respawn = "true"; stop_signal = 15;
                                               stop_time_allowed = 3; } }
                   cmd "b" { exec = "sleep 30"; host = "here"; })");
  PollUntil(
      *d, [] { return false; }, 0.7);
  EXPECT_FALSE(d->discovery_done());
  EXPECT_GE(heard.discovery.size(), 3U) << "every 200 ms";
  for (const auto& m : heard.discovery) {
    EXPECT_EQ(m.host, "here");
    EXPECT_EQ(m.nonce, 4242);
  }
  EXPECT_TRUE(heard.info.empty()) << "no report during discovery";
  ASSERT_TRUE(PollUntil(
      *d, [&] { return !heard.info.empty(); }, 2.0));
  EXPECT_TRUE(d->discovery_done());
  EXPECT_LE(heard.discovery.size(), 9U) << "discovery lasts 1.5 s";
  const bot_procman::info2_t& info = heard.info.back();
  EXPECT_EQ(info.host, "here");
  EXPECT_GT(info.phys_mem_total_bytes, 0);
  ASSERT_EQ(info.ncmds, 2);
  const auto* a = Find(info, "a");
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(a->cmd.exec_str, "$BIN/a --x=${RUN}") << "the sheet's text, as a deputy reports it";
  EXPECT_EQ(a->cmd.group, "drivers");
  EXPECT_TRUE(a->cmd.auto_respawn);
  EXPECT_EQ(a->cmd.stop_signal, 15);
  EXPECT_FLOAT_EQ(a->cmd.stop_time_allowed, 3.0F);
  EXPECT_EQ(a->sheriff_id, SheetSheriffId("here", "a"));
  EXPECT_EQ(a->pid, 0);
  EXPECT_EQ(a->actual_runid, 0);
  // A sheriff's discovery request is answered with a report at once.
  heard.info.clear();
  bot_procman::discovery_t ask{};
  ask.host = "";
  ask.nonce = 0;
  lcm_.publish(kDiscoverChannel, &ask);
  d->Poll();
  Drain();
  EXPECT_EQ(heard.info.size(), 1U);
}

TEST_F(DeputyTest, ASheriffStartsRestartsAndStopsItsCommands) {
  auto d = Make(R"(group "g" { cmd "a" { exec = "sleep 30"; host = "here"; } }
                   cmd "b" { exec = "sleep 30"; host = "here"; })");
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->discovery_done(); }, 2.0));
  Sheriff sheriff(lcm_, clock_, "test-sheriff");
  sheriff.Discover();
  const auto both = [&](const std::function<bool()>& done, double s) {
    return PollUntil(
        *d,
        [&] {
          sheriff.Poll();
          return done();
        },
        s);
  };
  ASSERT_TRUE(both([&] { return sheriff.deputies().count("here") == 1; }, 2.0));

  EXPECT_EQ(sheriff.Order(SheriffVerb::kStart, {true, "g"}, ""), std::vector<std::string>{"here"});
  ASSERT_TRUE(both([&] { return sheriff.Pending().empty(); }, 3.0));
  EXPECT_GT(d->state("a")->pid, 0);
  EXPECT_EQ(d->state("a")->actual_runid, 1);
  EXPECT_EQ(d->state("b")->pid, 0) << "not in the group";
  const int first_pid = d->state("a")->pid;

  // A restart is two orders: the first stops it, the re-sent one starts the new run.
  sheriff.Order(SheriffVerb::kRestart, {false, "a"}, "here");
  ASSERT_TRUE(both([&] { return sheriff.Pending().empty(); }, 5.0));
  EXPECT_GT(d->state("a")->pid, 0);
  EXPECT_NE(d->state("a")->pid, first_pid);
  EXPECT_EQ(d->state("a")->actual_runid, 2);

  sheriff.Order(SheriffVerb::kStop, {true, ""}, "");
  ASSERT_TRUE(both([&] { return sheriff.Pending().empty(); }, 5.0));
  EXPECT_EQ(d->state("a")->pid, 0);
  const bot_procman::info2_t& report = sheriff.deputies().at("here");
  const auto* a = Find(report, "a");
  ASSERT_NE(a, nullptr);
  EXPECT_TRUE(WIFSIGNALED(a->exit_code)) << "the raw wait status, as the deputy reports";
  EXPECT_EQ(WTERMSIG(a->exit_code), SIGINT);
  EXPECT_EQ(a->actual_runid, 2);
  EXPECT_NE(FormatDeputies(sheriff.deputies(), clock_.NowUtime()).find("signal 2"),
            std::string::npos);
}

TEST_F(DeputyTest, OrdersAddTheSheriffsCommandsAndRemoveTheOthers) {
  Heard heard(lcm_);
  auto d = Make(R"(cmd "a" { exec = "sleep 30"; host = "here"; })");
  d->Order(SheriffVerb::kStart, false, "a");
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->discovery_done(); }, 2.0));
  const int a_pid = d->state("a")->pid;
  ASSERT_GT(a_pid, 0);
  bot_procman::sheriff_cmd2_t n =
      CommandOrder("n", "K_TEST=from-the-sheet sh -c 'echo $K_TEST $(echo sub)'", 1, 777);
  n.cmd.group = "new";
  n.cmd.stop_signal = 15;
  n.cmd.stop_time_allowed = 2;
  const bot_procman::orders2_t orders = OrdersHolding(n, clock_.NowUtime());
  lcm_.publish(kOrdersChannel, &orders);
  ASSERT_TRUE(PollUntil(
      *d,
      [&] {
        return d->state("a") == nullptr && d->state("n") != nullptr &&
               d->state("n")->actual_runid == 1 && d->state("n")->pid == 0;
      },
      5.0));
  EXPECT_NE(kill(a_pid, 0), 0) << "the command left out of the orders was stopped";
  EXPECT_EQ(d->state("n")->command.group, "new");
  Drain();
  // Run without a shell: the deputy expands only $NAME from its own environment (K_TEST is
  // unset there, so "$K_TEST" reaches sh, which sees the child's setting).
  EXPECT_EQ(heard.Output(777), "from-the-sheet sub\n");
}

TEST_F(DeputyTest, KeepsUsableStopSettingsAgainstBadOrders) {
  Heard heard(lcm_);
  auto d = Make(R"(cmd "a" { exec = "sleep 30"; host = "here"; stop_signal = 15;
                             stop_time_allowed = 2; })");
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->discovery_done(); }, 2.0));
  bot_procman::sheriff_cmd2_t a = CommandOrder("a", "sleep 30", 1, SheetSheriffId("here", "a"));
  a.cmd.stop_signal = 0;  // no signal
  a.cmd.stop_time_allowed = std::nanf("");
  const bot_procman::orders2_t orders = OrdersHolding(a, clock_.NowUtime());
  lcm_.publish(kOrdersChannel, &orders);
  d->Poll();
  Drain();
  ASSERT_GT(d->state("a")->pid, 0) << "started all the same";
  EXPECT_EQ(d->state("a")->command.stop_signal, 15);
  EXPECT_DOUBLE_EQ(d->state("a")->command.stop_time_allowed_s, 2.0);
  EXPECT_NE(heard.Output(a.sheriff_id).find("ignoring stop_signal 0"), std::string::npos);
  EXPECT_NE(heard.Output(a.sheriff_id).find("ignoring stop_time_allowed nan"), std::string::npos);
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
  EXPECT_EQ(d->state("a")->exit_code, -15) << "stopped with the kept signal";
}

TEST_F(DeputyTest, IgnoresOrdersDuringDiscoveryForOthersAndStale) {
  Heard heard(lcm_);
  auto d = Make(R"(cmd "a" { exec = "sleep 30"; host = "here"; })");
  const bot_procman::sheriff_cmd2_t a =
      CommandOrder("a", "sleep 30", 1, SheetSheriffId("here", "a"));
  bot_procman::orders2_t orders = OrdersHolding(a, 0);
  const auto send = [&](const std::string& host, int64_t age_utime) {
    orders.host = host;
    orders.utime = clock_.NowUtime() - age_utime;
    lcm_.publish(kOrdersChannel, &orders);
    d->Poll();
  };
  send("here", 0);
  EXPECT_EQ(d->state("a")->pid, 0) << "orders before the end of discovery";
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->discovery_done(); }, 2.0));
  send("there", 0);
  send("Here", 0);
  EXPECT_EQ(d->state("a")->pid, 0) << "another deputy's orders (names match exactly)";
  send("here", 61'000'000);
  EXPECT_EQ(d->state("a")->pid, 0) << "orders a minute old";
  Drain();
  EXPECT_NE(heard.Output(a.sheriff_id).find("ignoring stale orders"), std::string::npos);
  send("here", 0);
  EXPECT_GT(d->state("a")->pid, 0);
  d->StopAll();
  ASSERT_TRUE(PollUntil(
      *d, [&] { return d->AllStopped(); }, 5.0));
}

TEST_F(DeputyTest, PublishesOutputAndExecFailures) {
  Heard heard(lcm_);
  auto d = Make(R"(cmd "t" { exec = "sh -c 'echo one; echo two'"; host = "here"; }
                   cmd "missing" { exec = "/nonexistent/kestrel-prog --x"; host = "here"; })");
  d->Order(SheriffVerb::kStart, true, "");
  ASSERT_TRUE(PollUntil(
      *d,
      [&] {
        return d->state("t")->state == procman_command_t::STATE_EXITED &&
               d->state("missing")->state == procman_command_t::STATE_EXITED;
      },
      5.0));
  Drain();
  EXPECT_EQ(heard.Output(SheetSheriffId("here", "t")), "one\ntwo\n") << "as written: no \\r";
  for (const auto& p : heard.printf) EXPECT_EQ(p.deputy_name, "here");
  EXPECT_NE(heard.Output(SheetSheriffId("here", "missing")).find("cannot execute"),
            std::string::npos);
  EXPECT_EQ(d->state("missing")->exit_code, 127);
  std::ifstream log(config_.log_dir + "/t.log");
  std::stringstream text;
  text << log.rdbuf();
  EXPECT_EQ(text.str(), "one\ntwo\n");
}

TEST_F(DeputyTest, RefusesANamesakeDeputy) {
  config_.discovery_nonce = 1;
  auto d = Make(R"(cmd "a" { exec = "sleep 30"; host = "here"; })");
  bot_procman::discovery_t other{};
  other.utime = clock_.NowUtime();
  other.host = "there";
  other.nonce = 2;
  lcm_.publish(kDiscoverChannel, &other);
  d->Poll();
  EXPECT_TRUE(d->name_conflict().empty()) << "another name";
  other.host = "here";
  other.nonce = 1;
  lcm_.publish(kDiscoverChannel, &other);
  d->Poll();
  EXPECT_TRUE(d->name_conflict().empty()) << "its own announcement";
  other.nonce = 2;
  lcm_.publish(kDiscoverChannel, &other);
  d->Poll();
  EXPECT_NE(d->name_conflict().find("another bot-procman deputy named 'here'"), std::string::npos);

  auto d2 = Make(R"(cmd "a" { exec = "sleep 30"; host = "here"; })");
  bot_procman::info2_t report{};
  report.host = "here";
  lcm_.publish(kInfoChannel, &report);
  d2->Poll();
  EXPECT_FALSE(d2->name_conflict().empty()) << "a deputy of the same name reports";
}

}  // namespace
}  // namespace kestrel::procman

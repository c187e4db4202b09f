// The node run loop: timers at the right simulated times, a clean exit on a signal.
#include "common/node_loop.h"

#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <thread>

#include <gtest/gtest.h>

namespace kestrel {
namespace {

TEST(NodeLoop, TimersFireAtTheirSimulatedTimesInOrder) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  SimClock clock(1000000);
  NodeLoop loop(lcm, clock);
  std::vector<std::pair<char, int64_t>> fired;
  loop.AddTimer("a", 100000, [&](int64_t t) { fired.emplace_back('a', t); });  // 10 Hz
  loop.AddTimer("b", 250000, [&](int64_t t) { fired.emplace_back('b', t); });  // 4 Hz
  loop.FireDueTimers();                                                        // arms at t = 1.0 s
  EXPECT_TRUE(fired.empty());
  clock.AdvanceUtime(99999);
  loop.FireDueTimers();
  EXPECT_TRUE(fired.empty()) << "nothing is due before 1.1 s";
  clock.AdvanceUtime(400001);  // jump to 1.5 s: catch up exactly, in time order
  loop.FireDueTimers();
  const std::vector<std::pair<char, int64_t>> expected = {
      {'a', 1100000}, {'a', 1200000}, {'b', 1250000}, {'a', 1300000},
      {'a', 1400000}, {'a', 1500000}, {'b', 1500000}};
  EXPECT_EQ(fired, expected);
  EXPECT_EQ(loop.skipped_ticks(), 0);
}

TEST(NodeLoop, TimerRejectsNonPositivePeriod) {
  lcm::LCM lcm("memq://");
  SimClock clock;
  NodeLoop loop(lcm, clock);
  EXPECT_THROW(loop.AddTimer("bad", 0, [](int64_t) {}), std::invalid_argument);
}

TEST(NodeLoop, HandlesMessagesThenStopsOnRequestAndRunsShutdownHooks) {
  lcm::LCM lcm("memq://");
  WallClock clock;
  NodeLoop loop(lcm, clock);
  int ticks = 0;
  bool flushed = false;
  loop.AddTimer("tick", 2000, [&](int64_t) {
    if (++ticks == 5) loop.RequestStop();
  });
  loop.AddShutdownHook([&] { flushed = true; });
  EXPECT_EQ(loop.Run(), 0);
  EXPECT_EQ(ticks, 5);
  EXPECT_TRUE(flushed);
}

// The microsecond wait: a queued message is handled at once; with nothing queued the loop waits
// the whole time-out (not less, and not rounded down to whole milliseconds).
TEST(NodeLoop, RunOnceMicrosecondsHandlesWhatIsQueuedAndWaitsTheWholeTimeout) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  WallClock clock;
  NodeLoop loop(lcm, clock);
  int received = 0;
  struct Handler {
    int* count;
    void On(const lcm::ReceiveBuffer*, const std::string&) { ++*count; }
  } handler{&received};
  lcm.subscribe("PING", &Handler::On, &handler);
  const uint8_t byte = 1;
  lcm.publish("PING", &byte, 1);
  ASSERT_TRUE(loop.RunOnceMicroseconds(0));
  EXPECT_EQ(received, 1);
  const int64_t start = clock.NowUtime();
  ASSERT_TRUE(loop.RunOnceMicroseconds(1500));
  EXPECT_GE(clock.NowUtime() - start, 1500) << "returned before its time-out";
  EXPECT_EQ(received, 1);
}

// A child process runs the loop; SIGTERM makes it run its shutdown hook and exit 0.
TEST(NodeLoop, ExitsCleanlyOnSigterm) {
  int pipe_fds[2];
  ASSERT_EQ(pipe(pipe_fds), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(pipe_fds[0]);
    lcm::LCM lcm("memq://");
    WallClock clock;
    NodeLoop loop(lcm, clock);
    NodeLoop::InstallSignalHandlers();
    loop.AddShutdownHook([&] {
      const char flushed = 'F';
      (void)!write(pipe_fds[1], &flushed, 1);
    });
    const char ready = 'R';
    (void)!write(pipe_fds[1], &ready, 1);
    // The signal is known by name, for the 128 + signal exit code of a tool that reports it.
    _exit(loop.Run() == 0 && NodeLoop::signal_received() &&
                  NodeLoop::received_signal() == SIGTERM &&
                  NodeLoop::ExitCodeForSignal(NodeLoop::received_signal()) == 143
              ? 0
              : 3);
  }
  close(pipe_fds[1]);
  char c = 0;
  ASSERT_EQ(read(pipe_fds[0], &c, 1), 1);
  EXPECT_EQ(c, 'R');
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  kill(pid, SIGTERM);
  ASSERT_EQ(read(pipe_fds[0], &c, 1), 1);
  EXPECT_EQ(c, 'F') << "the shutdown hook (final flush) ran";
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  close(pipe_fds[0]);
}

TEST(SimClock, NeverGoesBackwards) {
  SimClock clock(10);
  clock.AdvanceUtime(5);
  EXPECT_EQ(clock.NowUtime(), 15);
  EXPECT_THROW(clock.SetUtime(14), std::invalid_argument);
  EXPECT_THROW(clock.AdvanceUtime(-1), std::invalid_argument);
  EXPECT_TRUE(clock.is_simulated());
  EXPECT_FALSE(WallClock().is_simulated());
}

}  // namespace
}  // namespace kestrel

// libbot2 bot-procman's wire protocol (docs/protocols.md §5): the types' fingerprints and bytes
// against values computed from libbot2's definitions, the guarded decoder on them, and the pure
// rules of deputy and sheriff.
#include "common/procman/bot_procman.h"

#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "bot_procman/discovery_t.hpp"
#include "bot_procman/printf_t.hpp"
#include "common/lcm_decode.h"

namespace kestrel::procman {
namespace {

template <typename T>
std::string Hex(const T& msg) {
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  std::string out;
  char b[3];
  for (const uint8_t x : bytes) {
    std::snprintf(b, sizeof(b), "%02x", x);
    out += b;
  }
  return out;
}

std::vector<uint8_t> Bytes(const std::string& hex) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

// The first 8 bytes on the wire: LCM's recursive hash of libbot2's definitions (field names and
// types in order, nested types folded in), as lcm-gen computes it.
TEST(BotProcmanTypes, FingerprintsAreLibbot2s) {
  EXPECT_EQ(static_cast<uint64_t>(bot_procman::info2_t::getHash()), 0xd0cf2ed34edd8314ULL);
  EXPECT_EQ(static_cast<uint64_t>(bot_procman::orders2_t::getHash()), 0xef1277a9fdb17943ULL);
  EXPECT_EQ(static_cast<uint64_t>(bot_procman::printf_t::getHash()), 0x0abac44d8e3a7badULL);
  EXPECT_EQ(static_cast<uint64_t>(bot_procman::discovery_t::getHash()), 0x1116e1fff6333a71ULL);
}

TEST(BotProcmanTypes, EncodeToTheProtocolsBytes) {
  bot_procman::discovery_t d{};
  d.utime = 1;
  d.host = "h";
  d.nonce = 2;
  EXPECT_EQ(Hex(d),
            "1116e1fff6333a71"
            "0000000000000001"
            "00000002"
            "6800"
            "0000000000000002");

  bot_procman::printf_t p{};
  p.utime = 1000000;
  p.deputy_name = "d1";
  p.sheriff_id = 7;
  p.text = "hi\n";
  EXPECT_EQ(Hex(p),
            "0abac44d8e3a7bad"
            "00000000000f4240"
            "00000003"
            "643100"
            "00000007"
            "00000004"
            "68690a00");

  bot_procman::orders2_t o{};
  o.utime = 1;
  o.host = "h";
  o.sheriff_name = "S";
  bot_procman::sheriff_cmd2_t c{};
  c.cmd.exec_str = "sleep 5";
  c.cmd.command_name = "s";
  c.cmd.group = "g";
  c.cmd.auto_respawn = true;
  c.cmd.stop_signal = 2;
  c.cmd.stop_time_allowed = 7.0F;
  c.cmd.num_options = 0;
  c.desired_runid = 1;
  c.force_quit = 0;
  c.sheriff_id = 42;
  o.cmds = {c};
  o.ncmds = 1;
  o.num_options = 0;
  const std::string expected =
      "ef1277a9fdb17943"
      "0000000000000001"
      "00000002"
      "6800"
      "00000002"
      "5300"
      "00000001"
      "00000008"
      "736c656570203500"
      "00000002"
      "7300"
      "00000002"
      "6700"
      "01"
      "02"
      "40e00000"
      "00000000"
      "00000001"
      "00"
      "0000002a"
      "00000000";
  EXPECT_EQ(Hex(o), expected);
  EXPECT_EQ(expected.size() / 2, 79U);

  // The guarded decoder reads libbot2's bytes back, and refuses every truncation.
  const std::vector<uint8_t> bytes = Bytes(expected);
  bot_procman::orders2_t back;
  std::string error;
  ASSERT_TRUE(GuardedDecode(bytes.data(), bytes.size(), &back, &error)) << error;
  EXPECT_EQ(back.cmds.at(0).cmd.exec_str, "sleep 5");
  EXPECT_EQ(back.cmds.at(0).sheriff_id, 42);
  for (size_t n = 0; n < bytes.size(); ++n) {
    EXPECT_FALSE(GuardedDecode(bytes.data(), n, &back, &error)) << n << " bytes";
  }
  // A command count far beyond the bytes present is refused before anything is allocated.
  std::vector<uint8_t> hostile = bytes;
  hostile[8 + 8 + 6 + 6] = 0x7f;  // ncmds = 0x7f000001
  EXPECT_FALSE(GuardedDecode(hostile.data(), hostile.size(), &back, &error));
  EXPECT_NE(error.find("orders2_t.cmds"), std::string::npos) << error;
}

bot_procman::sheriff_cmd2_t Order(int32_t desired_runid, bool force_quit) {
  bot_procman::sheriff_cmd2_t c{};
  c.desired_runid = desired_runid;
  c.force_quit = force_quit ? 1 : 0;
  return c;
}

// The deputy's rule for one command, every case.
TEST(BotProcmanDeputy, DecidesAsTheDeputy) {
  EXPECT_EQ(DecideOrder(false, 3, Order(4, false)), OrderAction::kStart);
  EXPECT_EQ(DecideOrder(false, 3, Order(4, true)), OrderAction::kAdopt) << "force_quit wins";
  EXPECT_EQ(DecideOrder(false, 3, Order(3, false)), OrderAction::kAdopt) << "already ran";
  EXPECT_EQ(DecideOrder(false, 0, Order(0, false)), OrderAction::kAdopt) << "new, not started";
  EXPECT_EQ(DecideOrder(true, 3, Order(3, true)), OrderAction::kStop);
  EXPECT_EQ(DecideOrder(true, 3, Order(4, false)), OrderAction::kStop) << "restart: stop first";
  EXPECT_EQ(DecideOrder(true, 3, Order(3, false)), OrderAction::kAdopt);
}

bot_procman::info2_t Report() {
  bot_procman::info2_t info{};
  info.host = "jetson";
  const auto add = [&](const std::string& name, const std::string& group, int32_t id, int pid,
                       int32_t runid) {
    bot_procman::deputy_cmd2_t d{};
    d.cmd.command_name = name;
    d.cmd.group = group;
    d.cmd.exec_str = "run " + name;
    d.cmd.num_options = 1;  // a deputy's options are not echoed back
    d.cmd.option_names = {"x"};
    d.cmd.option_values = {"y"};
    d.sheriff_id = id;
    d.pid = pid;
    d.actual_runid = runid;
    info.cmds.push_back(d);
  };
  add("xtion", "drivers", 11, 100, 2);       // running
  add("hokuyo", "drivers/lidar", 12, 0, 1);  // stopped
  add("controller", "", 13, 300, 5);         // running
  info.ncmds = 3;
  return info;
}

TEST(BotProcmanSheriff, OrdersKeepEverythingButTheTarget) {
  const bot_procman::info2_t info = Report();
  const auto at = [](const bot_procman::orders2_t& o, int i) { return o.cmds.at(i); };

  const auto start = MakeOrders(info, "S", SheriffVerb::kStart, {true, "drivers"}, 99);
  EXPECT_EQ(start.host, "jetson");
  EXPECT_EQ(start.sheriff_name, "S");
  EXPECT_EQ(start.utime, 99);
  ASSERT_EQ(start.ncmds, 3);
  EXPECT_EQ(at(start, 0).desired_runid, 2) << "start leaves a running command alone";
  EXPECT_EQ(at(start, 1).desired_runid, 2) << "the group's subgroup: a new run";
  EXPECT_EQ(at(start, 2).desired_runid, 5) << "outside the target: as it is";
  for (const auto& c : start.cmds) {
    EXPECT_EQ(c.force_quit, 0);
    EXPECT_EQ(c.cmd.num_options, 0);
    EXPECT_TRUE(c.cmd.option_names.empty());
  }
  EXPECT_EQ(at(start, 1).cmd.exec_str, "run hokuyo");
  EXPECT_EQ(at(start, 1).sheriff_id, 12);

  const auto stop = MakeOrders(info, "S", SheriffVerb::kStop, {false, "xtion"}, 0);
  EXPECT_EQ(at(stop, 0).force_quit, 1);
  EXPECT_EQ(at(stop, 0).desired_runid, 2);
  EXPECT_EQ(at(stop, 1).force_quit, 0);
  EXPECT_EQ(at(stop, 2).force_quit, 0);

  const auto restart = MakeOrders(info, "S", SheriffVerb::kRestart, {true, ""}, 0);
  EXPECT_EQ(at(restart, 0).desired_runid, 3);
  EXPECT_EQ(at(restart, 1).desired_runid, 2);
  EXPECT_EQ(at(restart, 2).desired_runid, 6);

  // "drivers" does not name "drivers2"; a command name is matched whole.
  EXPECT_FALSE((CommandTarget{true, "drivers"}.Matches("a", "drivers2")));
  EXPECT_FALSE((CommandTarget{false, "xtio"}.Matches("xtion", "")));
}

TEST(BotProcmanSheriff, FulfilledOnceTheReportShowsTheOrders) {
  bot_procman::info2_t info = Report();
  const auto restart = MakeOrders(info, "S", SheriffVerb::kRestart, {false, "xtion"}, 0);
  EXPECT_FALSE(OrdersFulfilled(info, restart));
  info.cmds[0].pid = 0;  // the restart's first half: stopped
  EXPECT_FALSE(OrdersFulfilled(info, restart));
  info.cmds[0].pid = 101;
  info.cmds[0].actual_runid = 3;
  EXPECT_TRUE(OrdersFulfilled(info, restart));

  const auto stop = MakeOrders(info, "S", SheriffVerb::kStop, {true, ""}, 0);
  EXPECT_FALSE(OrdersFulfilled(info, stop));
  for (auto& c : info.cmds) c.pid = 0;
  EXPECT_TRUE(OrdersFulfilled(info, stop));
  info.cmds.pop_back();
  EXPECT_FALSE(OrdersFulfilled(info, stop)) << "a command missing from the report";
}

TEST(BotProcmanDeputy, SheetSheriffIdsAreStablePositiveAndDistinct) {
  EXPECT_EQ(SheetSheriffId("jetson", "xtion"), SheetSheriffId("jetson", "xtion"));
  EXPECT_NE(SheetSheriffId("jetson", "xtion"), SheetSheriffId("base", "xtion"));
  std::vector<int32_t> ids;
  for (int i = 0; i < 1000; ++i) {
    const int32_t id = SheetSheriffId("h", "cmd" + std::to_string(i));
    EXPECT_GT(id, 0);
    ids.push_back(id);
  }
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(std::adjacent_find(ids.begin(), ids.end()), ids.end());
}

TEST(BotProcmanDeputy, MachineFiguresFromProc) {
  const CpuTimes cpu =
      ParseProcStatCpu("cpu  100 20 30 850 5 0 1 0 0 0\ncpu0 50 10 15 425 2 0 0 0 0 0\nintr 1\n");
  EXPECT_EQ(cpu.busy, 150U);
  EXPECT_EQ(cpu.total, 1000U);
  EXPECT_THROW((void)ParseProcStatCpu("cpu0 1 2 3 4\n"), std::runtime_error);
  EXPECT_THROW((void)ParseProcStatCpu("cpu  1 2 x\n"), std::runtime_error);

  const MemoryFigures m = ParseMeminfo(
      "MemTotal:       16000000 kB\nMemFree:         2000000 kB\nMemAvailable:    9000000 kB\n"
      "SwapTotal:       1000 kB\nSwapFree:         500 kB\n");
  EXPECT_EQ(m.phys_total_bytes, 16000000LL * 1024);
  EXPECT_EQ(m.phys_free_bytes, 2000000LL * 1024) << "MemFree, as the deputy";
  EXPECT_EQ(m.swap_total_bytes, 1000 * 1024);
  EXPECT_EQ(m.swap_free_bytes, 500 * 1024);

  // A command name with spaces and parentheses; fields counted from the last ')'.
  const ProcessFigures p = ParseProcessStat(
      "4242 (my (odd) name) S 1 4242 4242 0 -1 4194560 100 0 0 0 77 23 0 0 20 0 1 0 12345 "
      "987654321 2048 18446744073709551615 1 1 0 0 0 0 0 0 0 0 0 0 17 1 0 0 0 0 0\n");
  EXPECT_EQ(p.cpu_jiffies, 100U);
  EXPECT_EQ(p.vsize_bytes, 987654321);
  EXPECT_EQ(p.rss_pages, 2048);
  EXPECT_THROW((void)ParseProcessStat("4242 (x) S 1 2 3\n"), std::runtime_error);
  EXPECT_THROW((void)ParseProcessStat("no parenthesis"), std::runtime_error);
}

}  // namespace
}  // namespace kestrel::procman

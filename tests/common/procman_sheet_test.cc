// Process sheets in bot-procman's format: what parses, and every refusal names its line.
#include "common/procman/sheet.h"

#include <gtest/gtest.h>

namespace kestrel::procman {
namespace {

const char* const kSheet = R"(# Kestrel sim sheet
cmd "sim" {
    exec = "kestrel-sim --config config/sim.yaml";
    host = "host";
}
group "vehicle" {
    cmd "controller" {
        exec = "LCM_DEFAULT_URL=udpm://239.255.76.67:7667?ttl=0 kestrel-controller";
        host = "jetson";
        auto_respawn = "true";
        stop_signal = 15;
        stop_time_allowed = 3;
    }
    group "sensors" {
        cmd "hokuyo" { exec = "kestrel-hokuyo"; host = "jetson"; }
    }
}
script "go" {
    start cmd "sim" wait "running";
    wait ms 500;
    start group "vehicle/sensors";
    restart cmd "controller";
    wait group "vehicle" status "running";
    run_script "other";
    stop group "vehicle" wait "stopped";
}
script "other" { stop cmd "sim"; }
)";

TEST(ProcmanSheet, ParsesCommandsGroupsAndScripts) {
  const Sheet s = ParseSheet(kSheet, "sim.procman");
  ASSERT_EQ(s.commands.size(), 3u);
  const Command* c = s.FindCommand("controller");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->host, "jetson");
  EXPECT_EQ(c->group, "vehicle");
  EXPECT_TRUE(c->auto_respawn);
  EXPECT_EQ(c->stop_signal, 15);
  EXPECT_EQ(c->stop_time_allowed_s, 3);
  EXPECT_EQ(c->line, 7);
  const Command* sim = s.FindCommand("sim");
  EXPECT_FALSE(sim->auto_respawn);
  EXPECT_EQ(sim->stop_signal, 2) << "procman's default stop signal is SIGINT";
  EXPECT_EQ(sim->stop_time_allowed_s, 7) << "procman's default stop time is 7 s";
  EXPECT_EQ(s.FindCommand("hokuyo")->group, "vehicle/sensors");
  EXPECT_EQ(s.CommandsInGroup("vehicle").size(), 2u) << "subgroups belong to their parent";
  EXPECT_EQ(s.CommandsInGroup("vehicle/sensors").size(), 1u);
  const Script* go = s.FindScript("go");
  ASSERT_NE(go, nullptr);
  ASSERT_EQ(go->actions.size(), 7u);
  EXPECT_EQ(go->actions[0].kind, ScriptAction::Kind::kStart);
  EXPECT_EQ(go->actions[0].wait_status, "running");
  EXPECT_EQ(go->actions[1].kind, ScriptAction::Kind::kWaitMs);
  EXPECT_EQ(go->actions[1].wait_ms, 500);
  EXPECT_TRUE(go->actions[2].target_is_group);
  EXPECT_EQ(go->actions[2].target, "vehicle/sensors");
  EXPECT_EQ(go->actions[3].kind, ScriptAction::Kind::kRestart);
  EXPECT_EQ(go->actions[4].kind, ScriptAction::Kind::kWaitStatus);
  EXPECT_EQ(go->actions[5].kind, ScriptAction::Kind::kRunScript);
  EXPECT_EQ(go->actions[6].wait_status, "stopped");
}

/// Expects ParseSheet to refuse `text` with a message holding "f.procman:LINE:" and `reason`.
void ExpectRefused(const std::string& text, int line, const std::string& reason) {
  try {
    (void)ParseSheet(text, "f.procman");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("f.procman:" + std::to_string(line) + ":"), std::string::npos) << what;
    EXPECT_NE(what.find(reason), std::string::npos) << what;
  }
}

TEST(ProcmanSheet, MalformedSheetsAreRefusedWithLineNumbers) {
  ExpectRefused("cmd \"a\" {\n exec = \"x\";\n host = \"h\";\n colour = \"red\";\n}\n", 4,
                "unknown attribute 'colour'");
  ExpectRefused("cmd \"a\" {\n host = \"h\";\n}\n", 1, "has no exec");
  ExpectRefused("cmd \"a\" {\n exec = \"x\";\n}\n", 1, "has no host");
  ExpectRefused("cmd \"a\" {\n exec = \"x;\n host = \"h\";\n}\n", 2, "unterminated string");
  ExpectRefused("cmd \"a\" {\n exec = \"x\"\n host = \"h\";\n}\n", 3, "expected ';'");
  ExpectRefused(
      "cmd \"a\" { exec = \"x\"; host = \"h\"; }\n\ncmd \"a\" { exec = \"y\"; host = \"h\"; }\n", 3,
      "duplicate cmd \"a\"");
  ExpectRefused("cmd \"a\" { exec = \"x\"; host = \"h\"; auto_respawn = \"yes\"; }\n", 1,
                "auto_respawn must be");
  ExpectRefused("cmd \"a\" { exec = \"x\"; host = \"h\"; stop_signal = 99; }\n", 1,
                "integer in [1, 64]");
  ExpectRefused("group \"g\" {\n cmd \"a\" { exec = \"x\"; host = \"h\"; }\n", 3, "missing '}'");
  ExpectRefused("group \"a/b\" { }\n", 1, "'/' is not allowed");
  ExpectRefused("cmd \"a\" { exec = \"x\"; host = \"h\"; }\nscript \"s\" {\n start cmd \"b\";\n}\n",
                3, "unknown cmd \"b\"");
  ExpectRefused(
      "cmd \"a\" { exec = \"x\"; host = \"h\"; }\nscript \"s\" {\n start cmd \"a\" wait "
      "\"done\";\n}\n",
      3, "\"running\" or \"stopped\"");
  ExpectRefused("cmd \"a\" { exec = \"x\"; host = \"h\"; }\nscript \"s\" { fly cmd \"a\"; }\n", 2,
                "unknown script action 'fly'");
  ExpectRefused("command \"a\" { }\n", 1, "expected cmd, group or script");
}

// Groups nest by recursion: a sheet of 100000 nested groups (a megabyte) is refused with its
// line, not a stack overflow; 32 levels still parse.
TEST(ProcmanSheet, DeeplyNestedGroupsAreRefused) {
  std::string deep;
  for (int i = 0; i < 100000; ++i) deep += "group \"g\" {\n";
  ExpectRefused(deep, 33, "groups nested deeper than 32");
  std::string ok;
  for (int i = 0; i < 32; ++i) ok += "group \"g\" {\n";
  ok += "cmd \"a\" { exec = \"x\"; host = \"h\"; }\n" + std::string(32, '}');
  const Sheet sheet = ParseSheet(ok, "ok.procman");
  ASSERT_EQ(sheet.commands.size(), 1u);
  EXPECT_EQ(sheet.commands[0].group.size(), 32u * 2 - 1);
}

}  // namespace
}  // namespace kestrel::procman

// The shared command line (common/process.h ParseCommandLine, common/command_line.h checks):
// every process's options go through it, so a mistyped option or a malformed number is refused
// with a message that names it, before anything runs.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/command_line.h"
#include "common/process.h"

namespace kestrel {
namespace {

/// Parses `words` (argv without the program name) with a takeoff-like set of own options.
struct Parsed {
  ProcessArgs args;
  bool run = false;
  double height_m = 1.0;
  double seconds = 2.0;
  bool verbose = false;
  std::vector<std::string> words;
};

Parsed Parse(const std::vector<std::string>& words) {
  Parsed p;
  std::vector<const char*> argv{"kestrel-test"};
  for (const auto& w : words) argv.push_back(w.c_str());
  p.run = ParseCommandLine(
      static_cast<int>(argv.size()), argv.data(),
      [&p](CLI::App& app) {
        app.add_option("--height", p.height_m)->check(cli::Positive());
        app.add_option("--seconds", p.seconds)->check(cli::Within(0.5, 60.0));
        app.add_flag("--verbose", p.verbose);
        app.add_option("words", p.words);
      },
      &p.args);
  return p;
}

std::string Refusal(const std::vector<std::string>& words) {
  try {
    (void)Parse(words);
  } catch (const CommandLineError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(CommandLine, CommonAndOwnOptionsInAnyOrder) {
  const Parsed p =
      Parse({"takeoff", "--set", "a.b=1", "--height", "2.5", "--set=c=x", "now", "--config",
             "f.yaml", "--lcm-url=memq://", "--verbose", "--sim-clock", "SIM_TRUTH"});
  EXPECT_TRUE(p.run);
  EXPECT_EQ(p.args.overrides, (std::vector<std::string>{"a.b=1", "c=x"}));
  EXPECT_EQ(p.args.config_path, "f.yaml");
  EXPECT_EQ(p.args.lcm_url, "memq://");
  EXPECT_EQ(p.args.sim_clock_channel, "SIM_TRUTH");
  EXPECT_DOUBLE_EQ(p.height_m, 2.5);
  EXPECT_TRUE(p.verbose);
  // One value per --set: "now" after "--set=c=x" stays a word.
  EXPECT_EQ(p.words, (std::vector<std::string>{"takeoff", "now"}));
}

TEST(CommandLine, DefaultsStandWhenNotGiven) {
  const Parsed p = Parse({"land"});
  EXPECT_DOUBLE_EQ(p.height_m, 1.0);
  EXPECT_DOUBLE_EQ(p.seconds, 2.0);
  EXPECT_FALSE(p.verbose);
  EXPECT_TRUE(p.args.overrides.empty());
}

TEST(CommandLine, MistypedOptionIsRefusedByName) {
  // The case that once took off to the default 1.0 m.
  EXPECT_NE(Refusal({"takeoff", "--hieght", "2"}).find("--hieght"), std::string::npos);
  EXPECT_NE(Refusal({"--verbos"}).find("--verbos"), std::string::npos);
}

TEST(CommandLine, MalformedAndOutOfRangeNumbersAreRefused) {
  EXPECT_NE(Refusal({"--height", "x"}).find("--height: 'x' is not a number"), std::string::npos);
  EXPECT_NE(Refusal({"--height", "2m"}).find("'2m' is not a number"), std::string::npos);
  EXPECT_NE(Refusal({"--height", "nan"}).find("'nan' is not a number"), std::string::npos);
  EXPECT_NE(Refusal({"--height", "-1"}).find("-1 is not above 0"), std::string::npos);
  EXPECT_NE(Refusal({"--height", "0"}).find("0 is not above 0"), std::string::npos);
  EXPECT_NE(Refusal({"--seconds", "0.4"}).find("0.4 is not in [0.5, 60]"), std::string::npos);
  EXPECT_NE(Refusal({"--seconds", "61"}).find("61 is not in [0.5, 60]"), std::string::npos);
  EXPECT_EQ(Refusal({"--seconds", "60"}), "(accepted)");
  EXPECT_EQ(Refusal({"--seconds", "0.5"}), "(accepted)");
}

TEST(CommandLine, MissingValueIsRefused) {
  EXPECT_NE(Refusal({"--height"}).find("--height"), std::string::npos);
  EXPECT_NE(Refusal({"--config"}).find("--config"), std::string::npos);
  EXPECT_NE(Refusal({"land", "--set"}).find("--set"), std::string::npos);
}

TEST(CommandLine, UnknownOptionIsNamedBeforeAMissingRequiredOne) {
  // "--wrold" for "--world": the refusal names the mistyping, not the consequence.
  ProcessArgs args;
  std::string world;
  const char* argv[] = {"kestrel-test", "--wrold", "w.yaml"};
  try {
    (void)ParseCommandLine(
        3, argv, [&world](CLI::App& app) { app.add_option("--world", world)->required(); }, &args);
    FAIL() << "accepted";
  } catch (const CommandLineError& e) {
    EXPECT_EQ(std::string(e.what()), "unknown option --wrold");
  }
}

TEST(CommandLine, HelpStopsEvenWithOtherMistakes) {
  EXPECT_FALSE(Parse({"--help"}).run);
  EXPECT_FALSE(Parse({"-h", "--hieght", "2"}).run);
}

TEST(CommandLine, NoOwnOptionsRefusesAnyExtraArgument) {
  ProcessArgs args;
  const char* argv[] = {"kestrel-test", "--set", "a=1", "extra"};
  try {
    (void)ParseCommandLine(4, argv, OptionDeclarer(), &args);
    FAIL() << "an extra argument was accepted";
  } catch (const CommandLineError& e) {
    EXPECT_NE(std::string(e.what()).find("extra"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kestrel

// A sheet command's exec string is executed the way a libbot2 bot-procman deputy executes it
// (docs/protocols.md §5.3): glib's shell-like splitting, leading NAME=value words, only $NAME and
// ${NAME} expanded, nothing else of a shell.
#include "common/procman/exec_line.h"

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <map>

#include <gtest/gtest.h>

namespace kestrel::procman {
namespace {

using Words = std::vector<std::string>;

VariableLookup Table(std::map<std::string, std::string> values) {
  return [values](const std::string& name) -> std::optional<std::string> {
    const auto it = values.find(name);
    if (it == values.end()) return std::nullopt;
    return it->second;
  };
}

const VariableLookup kVars =
    Table({{"BIN", "/opt/k/bin"}, {"RUN", "/tmp/r"}, {"A", "x"}, {"EMPTY", ""}, {"SPACED", "a b"}});

TEST(ExecLine, SplitsLikeAShellWithoutExpandingAnything) {
  EXPECT_EQ(ParseExecLine("prog  one\ttwo\nthree", kVars).argv,
            (Words{"prog", "one", "two", "three"}));
  EXPECT_EQ(ParseExecLine("prog 'a b' \"c d\" e\\ f", kVars).argv,
            (Words{"prog", "a b", "c d", "e f"}));
  EXPECT_EQ(ParseExecLine("prog \"q\\\"uote\" 'it''s'", kVars).argv,
            (Words{"prog", "q\"uote", "its"}));
  EXPECT_EQ(ParseExecLine("prog a # a comment", kVars).argv, (Words{"prog", "a"}));
  // What a shell would expand stays as written: globs, ~, command substitution, defaults.
  EXPECT_EQ(ParseExecLine("echo * ~ $(date) `id` ${A:-d} ${A:+alt} $((1+1))", kVars).argv,
            (Words{"echo", "*", "~", "$(date)", "`id`", "${A:-d}", "${A:+alt}", "$((1+1))"}));
  // Operators are ordinary words: no pipes, lists or redirections.
  EXPECT_EQ(ParseExecLine("a | b ; c > f && d", kVars).argv,
            (Words{"a", "|", "b", ";", "c", ">", "f", "&&", "d"}));
}

TEST(ExecLine, ExpandsDollarNameAndBracedNameOnly) {
  EXPECT_EQ(ParseExecLine("$BIN/kestrel-sim --set p=$RUN/m.kmap x${A}y", kVars).argv,
            (Words{"/opt/k/bin/kestrel-sim", "--set", "p=/tmp/r/m.kmap", "xxy"}));
  // Inside quotes too (the words are expanded after splitting), and a value is one word.
  EXPECT_EQ(ParseExecLine("p '$A' \"$SPACED\" $SPACED", kVars).argv,
            (Words{"p", "x", "a b", "a b"}));
  // Unset, empty name, malformed braces: left as written. Empty value: empty.
  EXPECT_EQ(ParseExecLine("p $NOPE ${NOPE} $ x$ ${A ${ $- ${A}$EMPTY", kVars).argv,
            (Words{"p", "$NOPE", "${NOPE}", "$", "x$", "${A", "${", "$-", "x"}));
  // The deputy's name rule: a digit only as the first character. "$A1" is $A then "1";
  // "${A1}" is malformed (the character after the name is not '}').
  EXPECT_EQ(ParseExecLine("p $A1 ${A1} $1", Table({{"A", "x"}, {"1", "one"}})).argv,
            (Words{"p", "x1", "${A1}", "one"}));
  // The deputy's expansion keeps a backslash and drops the character after it (reached only
  // by backslashes that survive the split, i.e. inside single quotes).
  EXPECT_EQ(ParseExecLine("p 'a\\$A' 'b\\'", kVars).argv, (Words{"p", "a\\A", "b\\"}));
}

TEST(ExecLine, LeadingAssignmentsAreTheChildsEnvironmentTakenLiterally) {
  const ExecLine line = ParseExecLine("LCM_DEFAULT_URL=udpm://x?ttl=0 V=$A prog W=1", kVars);
  ASSERT_EQ(line.environment.size(), 2U);
  EXPECT_EQ(line.environment[0].first, "LCM_DEFAULT_URL");
  EXPECT_EQ(line.environment[0].second, "udpm://x?ttl=0");
  EXPECT_EQ(line.environment[1].second, "$A") << "assignments are not expanded";
  EXPECT_EQ(line.argv, (Words{"prog", "W=1"})) << "only leading words are assignments";
  EXPECT_TRUE(ParseExecLine("A=1 B=2", kVars).argv.empty()) << "nothing to run";
}

TEST(ExecLine, FallsBackToBlankSplittingWhereGlibRefuses) {
  // An unmatched quote: split on blanks, no assignments, no expansion (the deputy's fallback).
  const ExecLine line = ParseExecLine("V=1 prog 'open $A", kVars);
  EXPECT_TRUE(line.environment.empty());
  EXPECT_EQ(line.argv, (Words{"V=1", "prog", "'open", "$A"}));
  EXPECT_TRUE(ParseExecLine("", kVars).argv.empty());
  EXPECT_TRUE(ParseExecLine(" \t", kVars).argv.empty());
}

TEST(ExecLine, ResolvesProgramsAsExecvp) {
  char dir[] = "/tmp/kestrel-exec-line-XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  const std::string tool = std::string(dir) + "/tool";
  std::ofstream(tool) << "#!/bin/sh\n";
  const std::string plain = std::string(dir) + "/plain";
  std::ofstream(plain) << "data\n";
  ASSERT_EQ(chmod(tool.c_str(), 0755), 0);
  EXPECT_EQ(ResolveProgram("tool", std::string("/nonexistent:") + dir), tool);
  EXPECT_EQ(ResolveProgram(tool, ""), tool) << "a path is taken as it is";
  EXPECT_FALSE(ResolveProgram("plain", dir)) << "not executable";
  EXPECT_FALSE(ResolveProgram("tool", "/nonexistent"));
  EXPECT_FALSE(ResolveProgram("", dir));
  unlink(tool.c_str());
  unlink(plain.c_str());
  rmdir(dir);
}

TEST(ExecLine, EnvironmentDefaultsAreNameValueLines) {
  const auto d = ParseEnvironmentDefaults(
      "# comment\n\nKESTREL_BIN=build/bin\nMIN=[0.5,-8.3,-0.15]\n  # indented comment\nE=\n"
      "Q=a b=c\n",
      "k.env");
  ASSERT_EQ(d.size(), 4U);
  EXPECT_EQ(d[0].name, "KESTREL_BIN");
  EXPECT_EQ(d[0].value, "build/bin");
  EXPECT_EQ(d[0].line, 3);
  EXPECT_EQ(d[1].value, "[0.5,-8.3,-0.15]");
  EXPECT_EQ(d[2].value, "");
  EXPECT_EQ(d[3].value, "a b=c") << "the rest of the line, literally";
  for (const char* bad : {"NOVALUE\n", "=x\n", "1A=x\n", "A-B=x\n", " A=x\n"}) {
    try {
      (void)ParseEnvironmentDefaults(std::string("OK=1\n") + bad, "k.env");
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("k.env:2: expected NAME=value", 0), 0U) << e.what();
    }
  }
}

}  // namespace
}  // namespace kestrel::procman

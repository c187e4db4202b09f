// The run-state file (common/run_state_file.h): written atomically, read back for the same run
// only, a corrupt file refused with a reason that says why.
#include "common/run_state_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace kestrel {
namespace {

class RunStateFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char dir[] = "/tmp/kestrel-run-state-XXXXXX";
    ASSERT_NE(mkdtemp(dir), nullptr);
    dir_ = dir;
    path_ = dir_ + "/controller.state";
  }
  void TearDown() override {
    std::remove(path_.c_str());
    std::remove((path_ + ".tmp").c_str());
    rmdir(dir_.c_str());
  }
  void WriteRaw(const std::string& text) { std::ofstream(path_) << text; }
  static RunStateFile Sample(const std::string& mode) {
    RunStateFile f;
    f.kind = "controller";
    f.run_id = "20261204T151000Z-0000abcd";
    f.values["mode"] = mode;
    f.values["ground_z_m"] = "0.05";
    return f;
  }
  std::string dir_, path_;
};

TEST_F(RunStateFileTest, RoundTripsAndReplacesAtomically) {
  std::string error;
  ASSERT_TRUE(WriteRunStateFile(path_, Sample("HOLD"), &error)) << error;
  // A kill in the middle of a write leaves a partial temporary file: the file itself is intact,
  // and the next write replaces both.
  std::ofstream(path_ + ".tmp") << "kestrel-state contr";
  RunStateFile read;
  ASSERT_EQ(ReadRunStateFile(path_, "controller", "20261204T151000Z-0000abcd", &read, &error),
            RunStateRead::kOk)
      << error;
  EXPECT_EQ(*read.Find("mode"), "HOLD");
  double z = 0;
  EXPECT_TRUE(read.GetDouble("ground_z_m", &z));
  EXPECT_DOUBLE_EQ(z, 0.05);
  ASSERT_TRUE(WriteRunStateFile(path_, Sample("LAND"), &error)) << error;
  EXPECT_NE(access((path_ + ".tmp").c_str(), F_OK), 0) << "the temporary file was renamed";
  ASSERT_EQ(ReadRunStateFile(path_, "controller", "20261204T151000Z-0000abcd", &read, &error),
            RunStateRead::kOk);
  EXPECT_EQ(*read.Find("mode"), "LAND");
  EXPECT_EQ(read.Find("absent"), nullptr);
  RunStateFile bad = Sample("two words");
  EXPECT_FALSE(WriteRunStateFile(path_, bad, &error));
  EXPECT_NE(error.find("bad entry"), std::string::npos) << error;
}

TEST_F(RunStateFileTest, MakesTheRunFolder) {
  const std::string folder = dir_ + "/run";
  const std::string path = folder + "/explorer.state";
  RunStateFile f = Sample("HOLD");
  std::string error;
  ASSERT_TRUE(WriteRunStateFile(path, f, &error)) << error;
  RunStateFile read;
  EXPECT_EQ(ReadRunStateFile(path, "controller", f.run_id, &read, &error), RunStateRead::kOk);
  std::remove(path.c_str());
  rmdir(folder.c_str());
}

TEST_F(RunStateFileTest, AnotherRunIsReportedNotUsed) {
  std::string error;
  ASSERT_TRUE(WriteRunStateFile(path_, Sample("TRACK"), &error)) << error;
  RunStateFile read;
  EXPECT_EQ(ReadRunStateFile(path_, "controller", "another-run", &read, &error),
            RunStateRead::kOtherRun);
  EXPECT_NE(error.find("belongs to run 20261204T151000Z-0000abcd"), std::string::npos) << error;
  EXPECT_EQ(ReadRunStateFile(dir_ + "/none.state", "controller", "x", &read, &error),
            RunStateRead::kAbsent);
}

TEST_F(RunStateFileTest, CorruptFilesAreRefusedWithTheReason) {
  struct Case {
    const char* text;
    const char* why;
  };
  const Case cases[] = {
      {"", "truncated"},
      {"garbage\n", "not a kestrel state file"},
      {"kestrel-state explorer 1\nrun_id r\n", "a explorer state file, expected controller"},
      {"kestrel-state controller 2\nrun_id r\n", "version 2"},
      {"kestrel-state controller 1\n", "truncated"},
      {"kestrel-state controller 1\nmode HOLD\n", "the second line must be the run id"},
      {"kestrel-state controller 1\nrun_id r\nmode\n", "expected 'key value'"},
      {"kestrel-state controller 1\nrun_id r\nmode HOLD\nmode IDLE\n", "given twice"},
  };
  for (const Case& c : cases) {
    WriteRaw(c.text);
    RunStateFile read;
    std::string error;
    EXPECT_EQ(ReadRunStateFile(path_, "controller", "r", &read, &error), RunStateRead::kCorrupt)
        << c.text;
    EXPECT_NE(error.find("corrupt state file " + path_), std::string::npos) << error;
    EXPECT_NE(error.find(c.why), std::string::npos) << c.text << " -> " << error;
  }
}

}  // namespace
}  // namespace kestrel

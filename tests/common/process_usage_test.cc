#include "common/process_usage.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

namespace kestrel {
namespace {

// The fields of a real /proc/<pid>/status text (Linux 6.1), and -1 for those it lacks.
TEST(ProcessUsage, ParsesProcStatus) {
  const ProcessUsage u = ParseProcStatus(
      "Name:\tkestrel-mission\nUmask:\t0022\nState:\tR (running)\nVmPeak:\t  912340 kB\n"
      "VmHWM:\t  402112 kB\nVmRSS:\t  398764 kB\nRssAnon:\t  380000 kB\nThreads:\t3\n"
      "voluntary_ctxt_switches:\t12\n");
  EXPECT_EQ(u.rss_kib, 398764);
  EXPECT_EQ(u.peak_rss_kib, 402112);
  EXPECT_EQ(u.threads, 3);
  EXPECT_EQ(u.open_files, -1);
  const ProcessUsage none = ParseProcStatus("Name:\tx\nVmRSS:\tgarbage kB\n");
  EXPECT_EQ(none.rss_kib, -1);
  EXPECT_EQ(none.peak_rss_kib, -1);
  EXPECT_EQ(none.threads, -1);
}

// This process: an opened file counts one more, and 64 MiB written count in the resident set.
TEST(ProcessUsage, SeesFilesAndMemoryOfThisProcess) {
  const std::optional<ProcessUsage> before = ReadProcessUsage();
  ASSERT_TRUE(before.has_value());
  ASSERT_GT(before->open_files, 0);
  ASSERT_GT(before->rss_kib, 0);
  ASSERT_GE(before->threads, 1);
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  std::vector<char> block(64u << 20, 1);
  const std::optional<ProcessUsage> after = ReadProcessUsage();
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->open_files, before->open_files + 1);
  EXPECT_GE(after->rss_kib - before->rss_kib, 60 * 1024);
  EXPECT_GE(after->peak_rss_kib, after->rss_kib);
  std::fclose(f);
  EXPECT_EQ(ReadProcessUsage()->open_files, before->open_files);
  EXPECT_EQ(block[12345], 1);
}

}  // namespace
}  // namespace kestrel

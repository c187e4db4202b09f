// LogTail reads an LCM log that is still being written: whole events only, and an event written
// in part is read once the rest arrives.
#include "common/log_tail.h"

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

namespace kestrel {
namespace {

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "kestrel_log_tail_test_" + std::to_string(::getpid()) + "_" + name;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void Append(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::app);
  out << bytes;
}

// One event through the LCM library's writer, as lcm-logger writes it: 0 on success.
int WriteEvent(lcm::LogFile* log, int64_t eventnum, int64_t timestamp, const std::string& channel,
               std::string data) {
  lcm::LogEvent e;
  e.eventnum = eventnum;
  e.timestamp = timestamp;
  e.channel = channel;
  e.datalen = static_cast<int32_t>(data.size());
  e.data = data.data();
  return log->writeEvent(&e);
}

// Three events written by the LCM library's writer, as lcm-logger writes them.
std::string WriteThreeEvents() {
  const std::string path = TempPath("whole.lcmlog");
  lcm::LogFile log(path, "w");
  EXPECT_TRUE(log.good());
  for (int i = 0; i < 3; ++i) {
    const std::string data(static_cast<size_t>(100 + 1000 * i), static_cast<char>('a' + i));
    EXPECT_EQ(WriteEvent(&log, i, 1000 + i, "CHANNEL_" + std::to_string(i), data), 0);
  }
  return path;
}

TEST(LogTail, ReadsWholeEventsAndWaitsForOnesWrittenInPart) {
  const std::string whole_path = WriteThreeEvents();
  const std::string whole = ReadAll(whole_path);
  // The third event cut in the middle of its data, then in the middle of its header.
  for (const size_t cut : {whole.size() - 500, whole.size() - 2100 - 20}) {
    SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(whole.size()));
    const std::string path = TempPath("growing.lcmlog");
    std::remove(path.c_str());
    Append(path, whole.substr(0, cut));
    LogTail tail(path);
    std::optional<LoggedEvent> e = tail.Next();
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->channel, "CHANNEL_0");
    EXPECT_EQ(e->timestamp, 1000);
    EXPECT_EQ(e->data, std::vector<uint8_t>(100, 'a'));
    ASSERT_TRUE(tail.Next().has_value());
    EXPECT_FALSE(tail.Next().has_value()) << "the third event is only partly written";
    EXPECT_FALSE(tail.Next().has_value());
    Append(path, whole.substr(cut));
    e = tail.Next();
    ASSERT_TRUE(e.has_value()) << "the rest has been written";
    EXPECT_EQ(e->channel, "CHANNEL_2");
    EXPECT_EQ(e->timestamp, 1002);
    EXPECT_EQ(e->data, std::vector<uint8_t>(2100, 'c'));
    EXPECT_FALSE(tail.Next().has_value());
    EXPECT_EQ(tail.events_read(), 3);
    std::remove(path.c_str());
  }
  std::remove(whole_path.c_str());
}

// A writer killed mid-event, then another appending: the broken event is cut first, and every
// whole event of both is read.
TEST(LogTail, TrimPartialLastEventLetsAnAppendingWriterBeRead) {
  const std::string whole_path = WriteThreeEvents();
  const std::string whole = ReadAll(whole_path);
  for (const size_t cut : {whole.size() - 500, whole.size() - 2100 - 20}) {
    SCOPED_TRACE("cut at " + std::to_string(cut));
    const std::string path = TempPath("appended.lcmlog");
    std::remove(path.c_str());
    Append(path, whole.substr(0, cut));
    // The third event: a 28-byte header, its 9-byte channel and 2100 bytes of data.
    const size_t two_events = whole.size() - (28 + 9 + 2100);
    EXPECT_EQ(TrimPartialLastEvent(path), static_cast<int64_t>(cut - two_events));
    EXPECT_EQ(TrimPartialLastEvent(path), 0) << "nothing left to cut";
    {
      lcm::LogFile log(path, "a");
      ASSERT_TRUE(log.good());
      ASSERT_EQ(WriteEvent(&log, 9, 2000, "NEXT_LIFE", std::string(7, 'z')), 0);
    }
    LogTail tail(path);
    std::vector<std::string> channels;
    while (std::optional<LoggedEvent> e = tail.Next()) channels.push_back(e->channel);
    EXPECT_EQ(channels, (std::vector<std::string>{"CHANNEL_0", "CHANNEL_1", "NEXT_LIFE"}));
    std::remove(path.c_str());
  }
  EXPECT_EQ(TrimPartialLastEvent(whole_path), 0) << "a log of whole events is left as it is";
  EXPECT_EQ(TrimPartialLastEvent(TempPath("none.lcmlog")), 0);
  std::remove(whole_path.c_str());
}

// The header-by-header walk against the events' true boundaries (the file's size after each
// was written): events whose data is full of the sync word and of headers, cut at every byte of
// the last two events. (The LCM reader itself leaves a lone first byte of an event uncut: its
// file position runs one byte past the last whole event when a byte follows it.)
TEST(LogTail, TrimPartialLastEventCutsAtTheLastWholeEventsEnd) {
  const std::string path = TempPath("sync_words.lcmlog");
  std::remove(path.c_str());
  std::vector<size_t> boundaries{0};
  std::mt19937 rng(7);
  for (int i = 0; i < 4; ++i) {
    std::string data;
    while (data.size() < 300) {
      // The sync word, then lengths that a reader could take for a header's.
      const char fake[] = {'\xED', '\xA1', '\xDA', '\x01'};
      data.append(fake, 4);
      data.append(16, static_cast<char>(rng() & 0xff));
      const uint32_t channel = 1 + rng() % 20, length = rng() % 400;
      for (const uint32_t v : {channel, length}) {
        for (int b = 3; b >= 0; --b) data.push_back(static_cast<char>((v >> (8 * b)) & 0xff));
      }
      data.append(rng() % 40, static_cast<char>(rng() & 0xff));
    }
    {
      lcm::LogFile log(path, i == 0 ? "w" : "a");
      ASSERT_TRUE(log.good());
      ASSERT_EQ(WriteEvent(&log, i, 1000 + i, "SYNC_" + std::to_string(i), data), 0);
    }
    boundaries.push_back(ReadAll(path).size());
  }
  const std::string whole = ReadAll(path);
  int checked = 0;
  for (size_t cut = boundaries[2]; cut <= whole.size(); ++cut) {
    const std::string cut_path = TempPath("sync_words_cut.lcmlog");
    std::remove(cut_path.c_str());
    Append(cut_path, whole.substr(0, cut));
    const size_t whole_end = *(std::upper_bound(boundaries.begin(), boundaries.end(), cut) - 1);
    ASSERT_EQ(TrimPartialLastEvent(cut_path), static_cast<int64_t>(cut - whole_end))
        << "cut at " << cut;
    ASSERT_EQ(ReadAll(cut_path).size(), whole_end);
    ++checked;
    std::remove(cut_path.c_str());
  }
  EXPECT_GT(checked, 600);
  std::remove(path.c_str());
}

TEST(LogTail, AMissingFileIsAClearError) {
  try {
    LogTail tail(TempPath("missing.lcmlog"));
    FAIL() << "opened a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open the LCM log"), std::string::npos);
  }
}

}  // namespace
}  // namespace kestrel

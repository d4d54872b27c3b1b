// The log line: logfmt with level, job and message; the journal's priority
// prefix under systemd, a UTC timestamp elsewhere.
#include "common/log.hpp"

#include <gtest/gtest.h>

#include <regex>

namespace tally::log {
namespace {

TEST(Log, JournalLinesCarryThePriorityAndNoTime) {
  EXPECT_EQ(format({Level::kInfo, 12, "running"}, true), "<6>level=info job=12 msg=running");
  EXPECT_EQ(format({Level::kError, 3, "failed: capture exited with 1"}, true),
            "<3>level=error job=3 msg=\"failed: capture exited with 1\"");
  EXPECT_EQ(format({Level::kWarning, std::nullopt, "interrupted"}, true), "<4>level=warning msg=interrupted");
}

TEST(Log, OtherLinesStartWithAUtcTimestamp) {
  std::string line = format({Level::kInfo, 7, "done, 2 runs"}, false);
  EXPECT_TRUE(std::regex_match(line, std::regex(R"(ts=\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z level=info job=7 msg="done, 2 runs")")))
      << line;
}

TEST(Log, AMessageStaysOnOneLine) {
  // A reason read from a child's stderr may hold newlines and quotes.
  std::string line = format({Level::kError, 1, "line one\nline \"two\"\\"}, true);
  EXPECT_EQ(line, "<3>level=error job=1 msg=\"line one\\nline \\\"two\\\"\\\\\"");
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_EQ(format({Level::kDebug, {}, ""}, true), "<7>level=debug msg=\"\"");
}

}  // namespace
}  // namespace tally::log

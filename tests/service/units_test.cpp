// The worker's progress-line parser and the export's CSV quoting.
#include <gtest/gtest.h>

#include "jobs/worker.hpp"
#include "service/service.hpp"

namespace {

TEST(ProgressLine, Parses) {
  auto p = tally::jobs::parseProgressLine("[3/12] deferred atrium 320x180 camera 2");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->done, 3);
  EXPECT_EQ(p->total, 12);
  EXPECT_EQ(p->current, "deferred atrium 320x180 camera 2");
  auto bare = tally::jobs::parseProgressLine("[0/1]");
  ASSERT_TRUE(bare);
  EXPECT_EQ(bare->current, "");
}

TEST(ProgressLine, RefusesOtherLines) {
  for (const char* line : {"", "warning: x", "[a/2] x", "[1/] x", "[1/2 x", "[-1/2] x", "[1x/2] y", "1/2] x"}) {
    EXPECT_FALSE(tally::jobs::parseProgressLine(line)) << line;
  }
}

TEST(CsvCell, QuotesWhenNeeded) {
  EXPECT_EQ(tally::service::csvCell("gbuffer.normal"), "gbuffer.normal");
  EXPECT_EQ(tally::service::csvCell("a,b"), "\"a,b\"");
  EXPECT_EQ(tally::service::csvCell("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(tally::service::csvCell("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(tally::service::csvCell("=cmd()"), "'=cmd()");  // no spreadsheet formulas
  EXPECT_EQ(tally::service::csvCell(""), "");
}

}  // namespace

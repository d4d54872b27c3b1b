// Child-process isolation: every way a capture child can end is reported
// with a reason, and the parent keeps going.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "jobs/child_process.hpp"

namespace tally::jobs {
namespace {

using namespace std::chrono_literals;

ChildResult run(const std::string& script, std::chrono::milliseconds deadline = 0ms,
                std::vector<std::string>* lines = nullptr, const std::string& stdoutPath = "") {
  ChildOptions options;
  options.argv = {"/bin/sh", "-c", script};
  options.deadline = deadline;
  options.grace = 300ms;
  options.stdoutPath = stdoutPath;
  if (lines) options.onStderrLine = [lines](const std::string& l) { lines->push_back(l); };
  auto r = runChild(options);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error());
  return r.ok() ? *r : ChildResult{};
}

TEST(ChildProcess, Success) {
  auto r = run("exit 0");
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.end, ChildResult::End::Exited);
}

TEST(ChildProcess, ExitStatusAndLastErrorLine) {
  auto r = run("echo 'spec: frames: must be an integer' >&2; exit 3");
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.exitCode, 3);
  EXPECT_EQ(r.reason(), "exited with status 3: spec: frames: must be an integer");
}

TEST(ChildProcess, CrashIsReportedBySignal) {
  auto r = run("kill -SEGV $$");
  EXPECT_EQ(r.end, ChildResult::End::Signaled);
  EXPECT_EQ(r.signal, SIGSEGV);
  EXPECT_NE(r.reason().find("SIGSEGV"), std::string::npos) << r.reason();
}

TEST(ChildProcess, KillNineReadsAsOutOfMemoryOrKilled) {
  auto r = run("kill -KILL $$");
  EXPECT_EQ(r.signal, SIGKILL);
  EXPECT_NE(r.reason().find("out of memory, or killed"), std::string::npos) << r.reason();
}

TEST(ChildProcess, HangIsKilledAtTheDeadlineWithItsChildren) {
  auto t0 = std::chrono::steady_clock::now();
  // The shell ignores SIGTERM; its sleeping child keeps the pipe open: only
  // SIGKILL to the whole group ends both.
  auto r = run("trap '' TERM; sleep 30 & sleep 30; wait", 400ms);
  auto elapsed = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(r.end, ChildResult::End::TimedOut);
  EXPECT_EQ(r.reason().rfind("timed out after", 0), 0u);
  EXPECT_LT(elapsed, 10s);
}

TEST(ChildProcess, ProgressLinesArriveAsTheyAreWritten) {
  std::vector<std::string> lines;
  auto r = run("for i in 1 2 3; do echo \"[$i/3] sample\" >&2; done; printf 'no newline' >&2", 0ms, &lines);
  EXPECT_TRUE(r.ok());
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "[1/3] sample");
  EXPECT_EQ(lines[3], "no newline");
}

TEST(ChildProcess, LargeOutputDoesNotBlock) {
  auto path = std::filesystem::temp_directory_path() / ("tally-child-" + std::to_string(getpid()));
  // 8 MB on stdout and 1 MB on stderr: neither pipe may fill up and stall the child.
  auto r = run("head -c 8000000 /dev/zero; head -c 1000000 /dev/zero | tr '\\0' 'x' >&2", 20s, nullptr,
               path.string());
  EXPECT_TRUE(r.ok()) << r.reason();
  EXPECT_EQ(std::filesystem::file_size(path), 8000000u);
  EXPECT_LE(r.stderrTail.size(), 4096u);
  std::filesystem::remove(path);
}

TEST(ChildProcess, MissingProgramIsAnErrorNotACrash) {
  ChildOptions options;
  options.argv = {"/nonexistent/tallyd", "capture"};
  auto r = runChild(options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("cannot start /nonexistent/tallyd"), std::string::npos) << r.error();
}

}  // namespace
}  // namespace tally::jobs

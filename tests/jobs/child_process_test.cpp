// Child-process isolation: every way a capture child can end is reported
// with a reason, and the parent keeps going.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <thread>
#include <vector>

#include "common/child_process.hpp"
#include "proc_file.hpp"

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

// Whether process `pid` has ended: no longer in /proc, or a zombie.
bool ended(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!std::getline(stat, text)) return true;
  size_t close = text.rfind(')');
  return close != std::string::npos && close + 2 < text.size() && text[close + 2] == 'Z';
}

TEST(ChildProcess, HangIsKilledAtTheDeadlineWithItsChildren) {
  // The shell ignores SIGTERM; its sleeping children keep the pipe open: only
  // SIGKILL to the whole group ends them all. Each child's pid is written
  // down, so that what is checked is that they ended, not how long it took.
  const auto pids = std::filesystem::temp_directory_path() / ("tally-child-pids-" + std::to_string(getpid()));
  std::filesystem::remove(pids);
  auto r = run("trap '' TERM; sleep 300 & echo $! >> " + pids.string() + "; sleep 300 & echo $! >> " + pids.string() +
                   "; wait",
               1000ms);
  EXPECT_EQ(r.end, ChildResult::End::TimedOut);
  EXPECT_EQ(r.reason().rfind("timed out after", 0), 0u);
  std::ifstream written(pids);
  std::vector<pid_t> children;
  for (pid_t pid; written >> pid;) children.push_back(pid);
  std::filesystem::remove(pids);
  ASSERT_FALSE(children.empty()) << "the shell wrote no child's pid within its 1 s";
  // Killed, they close the pipe while still exiting, before they are
  // zombies: wait for that end (bounded; a survivor never gets there).
  for (pid_t pid : children) {
    for (auto until = std::chrono::steady_clock::now() + 30s; !ended(pid) && std::chrono::steady_clock::now() < until;)
      std::this_thread::sleep_for(10ms);
    EXPECT_TRUE(ended(pid)) << "child " << pid << " outlived the deadline";
  }
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

// The state letter of /proc/PID/stat, or 0 when there is no such process.
char processState(pid_t pid) {
  std::string stat = tally::test::readProcFile("/proc/" + std::to_string(pid) + "/stat");
  size_t paren = stat.rfind(')');
  return paren == std::string::npos || paren + 2 >= stat.size() ? 0 : stat[paren + 2];
}

// The children of `parent`, from /proc/*/stat.
std::vector<pid_t> childrenOf(pid_t parent) {
  std::vector<pid_t> kids;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc", ec)) {
    std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string stat = tally::test::readProcFile(entry.path() / "stat");
    size_t paren = stat.rfind(')');
    if (paren == std::string::npos) continue;
    std::istringstream rest(stat.substr(paren + 2));
    char state;
    pid_t ppid = 0;
    rest >> state >> ppid;
    if (ppid == parent) kids.push_back(std::stoi(name));
  }
  return kids;
}

// A daemon killed with -9 runs no cleanup: its capture child must not render
// on to its deadline. A forked "daemon" runs a long child, then dies by SIGKILL;
// the child goes with it.
TEST(ChildProcess, ChildDiesWithAParentKilledByNine) {
  pid_t daemon = fork();
  ASSERT_GE(daemon, 0);
  if (daemon == 0) {
    ChildOptions options;
    options.argv = {"/bin/sleep", "30"};
    options.deadline = 60s;
    auto r = runChild(options);
    _exit(r.ok() ? 0 : 1);
  }
  std::vector<pid_t> kids;
  for (int i = 0; i < 200 && kids.empty(); ++i) {
    std::this_thread::sleep_for(10ms);
    kids = childrenOf(daemon);
  }
  ASSERT_EQ(kids.size(), 1u) << "the child did not start";
  pid_t child = kids[0];
  // Wait for the exec, so that the check is on sleep itself.
  std::string comm;
  for (int i = 0; i < 200 && comm != "sleep\n"; ++i) {
    comm = tally::test::readProcFile("/proc/" + std::to_string(child) + "/comm");
    if (comm != "sleep\n") std::this_thread::sleep_for(10ms);
  }
  ASSERT_EQ(comm, "sleep\n");
  ASSERT_EQ(kill(daemon, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(waitpid(daemon, &status, 0), daemon);
  // Gone, or a zombie waiting for whoever adopted it: either way it stopped running.
  char state = processState(child);
  for (int i = 0; i < 300 && state != 0 && state != 'Z'; ++i) {
    std::this_thread::sleep_for(10ms);
    state = processState(child);
  }
  EXPECT_TRUE(state == 0 || state == 'Z') << "the orphaned child is still running, state " << state;
  if (state != 0 && state != 'Z') kill(child, SIGKILL);
}

// environment: set over the parent's, a new name added, a bare name removed.
TEST(ChildProcess, EnvironmentOverParents) {
  setenv("TALLY_CHILD_TEST_KEEP", "parent", 1);
  setenv("TALLY_CHILD_TEST_OVER", "parent", 1);
  setenv("TALLY_CHILD_TEST_DROP", "parent", 1);
  ChildOptions options;
  options.argv = {"/bin/sh", "-c",
                  "echo \"$TALLY_CHILD_TEST_KEEP/$TALLY_CHILD_TEST_OVER/${TALLY_CHILD_TEST_DROP-unset}/$TALLY_CHILD_TEST_NEW\" >&2"};
  options.environment = {"TALLY_CHILD_TEST_OVER=child", "TALLY_CHILD_TEST_DROP", "TALLY_CHILD_TEST_NEW=a=b",
                         "TALLY_CHILD_TEST_OVER=later"};
  std::vector<std::string> lines;
  options.onStderrLine = [&](const std::string& l) { lines.push_back(l); };
  auto r = runChild(options);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_TRUE(r->ok()) << r->reason();
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "parent/later/unset/a=b");
  unsetenv("TALLY_CHILD_TEST_KEEP");
  unsetenv("TALLY_CHILD_TEST_OVER");
  unsetenv("TALLY_CHILD_TEST_DROP");
}

// shouldTerminate: SIGTERM to the group; a child that ignores it gets SIGKILL after the grace period.
TEST(ChildProcess, TerminateThenKill) {
  for (bool ignoresTerm : {false, true}) {
    ChildOptions options;
    options.argv = {"/bin/sh", "-c", std::string(ignoresTerm ? "trap '' TERM; " : "") + "echo ready >&2; while :; do sleep 0.05; done"};
    options.grace = 300ms;
    bool ready = false;
    options.onStderrLine = [&](const std::string& l) { ready = ready || l == "ready"; };
    options.shouldTerminate = [&] { return ready; };
    auto t0 = std::chrono::steady_clock::now();
    auto r = runChild(options);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_TRUE(r->terminated);
    EXPECT_EQ(r->end, ChildResult::End::Signaled);
    EXPECT_EQ(r->signal, ignoresTerm ? SIGKILL : SIGTERM) << r->reason();
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 5s);
  }
}

}  // namespace
}  // namespace tally::jobs

#include "jobs/child_process.hpp"

#include <cerrno>
#include <csignal>
#include <cstring>

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace tally::jobs {
namespace {

std::string lastLine(const std::string& text) {
  size_t end = text.find_last_not_of("\n\r ");
  if (end == std::string::npos) return {};
  size_t start = text.find_last_of('\n', end);
  return text.substr(start == std::string::npos ? 0 : start + 1, end - (start == std::string::npos ? 0 : start + 1) + 1);
}

}  // namespace

std::string ChildResult::reason() const {
  switch (end) {
    case End::Exited: {
      std::string r = "exited with status " + std::to_string(exitCode);
      std::string line = lastLine(stderrTail);
      return line.empty() ? r : r + ": " + line;
    }
    case End::Signaled: {
      const char* abbrev = sigabbrev_np(signal);
      std::string r = "killed by signal " + std::to_string(signal) + " (" + (abbrev ? "SIG" + std::string(abbrev) : "?");
      // The kernel's OOM killer sends SIGKILL; so does anyone with kill -9.
      if (signal == SIGKILL) r += ": out of memory, or killed";
      return r + ")";
    }
    case End::TimedOut:
      return "timed out after " + std::to_string(elapsed.count() / 1000) + " s";
  }
  return "unknown";
}

Result<ChildResult> runChild(const ChildOptions& options) {
  if (options.argv.empty()) return makeError("no command to run");
  int errPipe[2];
  if (pipe2(errPipe, O_CLOEXEC) != 0) return makeError(std::string("pipe: ") + std::strerror(errno));

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  std::string out = options.stdoutPath.empty() ? "/dev/null" : options.stdoutPath;
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, errPipe[1], STDERR_FILENO);
  // Its own process group, so that a deadline kills the child's children too.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);

  std::vector<char*> argv;
  for (const auto& a : options.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  auto start = std::chrono::steady_clock::now();
  int spawned = posix_spawn(&pid, argv[0], &actions, &attributes, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  close(errPipe[1]);
  if (spawned != 0) {
    close(errPipe[0]);
    return makeError("cannot start " + options.argv[0] + ": " + std::strerror(spawned));
  }

  ChildResult result;
  std::string pending;
  bool timedOut = false, killed = false;
  auto deadlineAt = start + options.deadline;
  auto killAt = deadlineAt + options.grace;
  // SIGTERM at the deadline, SIGKILL after the grace period, to the whole group.
  auto enforceDeadline = [&] {
    if (options.deadline.count() <= 0) return;
    auto now = std::chrono::steady_clock::now();
    if (!timedOut && now >= deadlineAt) {
      timedOut = true;
      kill(-pid, SIGTERM);
    }
    if (timedOut && !killed && now >= killAt) {
      killed = true;
      kill(-pid, SIGKILL);
    }
  };
  bool stopped = false;
  auto checkStop = [&] {
    if (!stopped && options.shouldStop && options.shouldStop()) {
      stopped = true;
      kill(-pid, SIGKILL);
    }
  };
  bool open = true;
  while (open) {
    int timeoutMs = 200;
    pollfd fd{errPipe[0], POLLIN, 0};
    int ready = poll(&fd, 1, timeoutMs);
    if (ready > 0) {
      char buffer[4096];
      ssize_t n = read(errPipe[0], buffer, sizeof buffer);
      if (n <= 0) {
        open = false;
      } else {
        pending.append(buffer, static_cast<size_t>(n));
        result.stderrTail.append(buffer, static_cast<size_t>(n));
        if (result.stderrTail.size() > options.stderrTailBytes) {
          result.stderrTail.erase(0, result.stderrTail.size() - options.stderrTailBytes);
        }
        size_t newline;
        while ((newline = pending.find('\n')) != std::string::npos) {
          if (options.onStderrLine) options.onStderrLine(pending.substr(0, newline));
          pending.erase(0, newline + 1);
        }
      }
    }
    enforceDeadline();
    checkStop();
  }
  close(errPipe[0]);
  // The pipe closes when the child (and whatever inherited it) exits; a child
  // that closed stderr early is still waited for under the same deadline.
  int status = 0;
  while (true) {
    pid_t done = waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) return makeError(std::string("waitpid: ") + std::strerror(errno));
    enforceDeadline();
    checkStop();
    usleep(20000);
  }
  if (!pending.empty() && options.onStderrLine) options.onStderrLine(pending);
  result.elapsed = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start);
  if (timedOut) {
    result.end = ChildResult::End::TimedOut;
    result.signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  } else if (WIFSIGNALED(status)) {
    result.end = ChildResult::End::Signaled;
    result.signal = WTERMSIG(status);
  } else {
    result.end = ChildResult::End::Exited;
    result.exitCode = WEXITSTATUS(status);
  }
  return result;
}

}  // namespace tally::jobs

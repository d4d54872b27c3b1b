#include "common/child_process.hpp"

#include <cerrno>
#include <csignal>
#include <cstring>

#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <pwd.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <map>

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

// fork + exec rather than posix_spawn, for the one thing posix_spawn cannot
// do: PR_SET_PDEATHSIG. A daemon killed with -9 runs no cleanup, and its
// capture child would otherwise render on to its deadline, holding the GPU
// while the restarted daemon retries the same job. Between fork and exec the
// child calls only async-signal-safe functions (the daemon is multithreaded).
// An exec failure comes back as an errno through a close-on-exec pipe.
Result<pid_t> spawnProcess(const std::vector<char*>& argv, const SpawnOptions& options) {
  int execPipe[2];
  if (pipe2(execPipe, O_CLOEXEC) != 0) return makeError(std::string("pipe: ") + std::strerror(errno));
  char** envp = options.envp != nullptr ? options.envp : environ;
  const pid_t parent = getpid();
  pid_t pid = fork();
  if (pid < 0) {
    int e = errno;
    close(execPipe[0]);
    close(execPipe[1]);
    return makeError(std::string("fork: ") + std::strerror(e));
  }
  if (pid == 0) {
    // Its own process group, so that a deadline kills the child's children too.
    if (options.ownProcessGroup) setpgid(0, 0);
    // Files first, as this process's user (the stdout file may be where only it may write).
    int in = open("/dev/null", O_RDONLY);
    int out = open(options.stdoutPath.empty() ? "/dev/null" : options.stdoutPath.c_str(),
                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = options.stderrFd >= 0 ? options.stderrFd : out;
    int e = 0;
    if (in < 0 || out < 0 || dup2(in, STDIN_FILENO) < 0 || dup2(out, STDOUT_FILENO) < 0 ||
        dup2(err, STDERR_FILENO) < 0) {
      e = errno;
    } else if (options.passFd >= 0 && options.passFd == options.passAs &&
               fcntl(options.passAs, F_SETFD, 0) < 0) {  // already there: keep it across exec
      e = errno;
    } else if (options.passFd >= 0 && options.passFd != options.passAs && dup2(options.passFd, options.passAs) < 0) {
      e = errno;
    } else if (options.runAs != nullptr &&
               (setgroups(options.runAs->groups.size(), options.runAs->groups.data()) != 0 ||
                setgid(options.runAs->gid) != 0 || setuid(options.runAs->uid) != 0)) {
      e = errno;  // never exec as the wrong user
    } else if (options.runAs != nullptr &&
               (getuid() != options.runAs->uid || geteuid() != options.runAs->uid)) {
      e = EPERM;
    } else {
      // After the change of user, which clears the parent-death signal.
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != parent) _exit(127);  // the daemon died before prctl took effect
      execve(argv[0], argv.data(), envp);
      e = errno;
    }
    ssize_t ignored = write(execPipe[1], &e, sizeof e);
    (void)ignored;
    _exit(127);
  }
  close(execPipe[1]);
  int childErrno = 0;
  ssize_t n;
  do {
    n = read(execPipe[0], &childErrno, sizeof childErrno);
  } while (n < 0 && errno == EINTR);
  close(execPipe[0]);
  if (n == static_cast<ssize_t>(sizeof childErrno)) {
    waitpid(pid, nullptr, 0);
    return makeError(std::strerror(childErrno));
  }
  return pid;
}

namespace {

// The parent's environment with `overrides` ("NAME=VALUE") set over it, in
// the parent's order and then the new names'; a bare "NAME" removes NAME
// (built before fork: nothing between fork and exec may allocate).
std::vector<std::string> mergedEnvironment(const std::vector<std::string>& overrides) {
  std::map<std::string, std::string> set;
  std::vector<std::string> added;
  for (const auto& entry : overrides) {
    std::string name = entry.substr(0, entry.find('='));
    if (!set.count(name)) added.push_back(name);
    set[name] = entry;
  }
  std::vector<std::string> out;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    std::string entry = *e;
    auto it = set.find(entry.substr(0, entry.find('=')));
    if (it == set.end()) {
      out.push_back(std::move(entry));
    } else if (!it->second.empty()) {
      if (it->second.find('=') != std::string::npos) out.push_back(it->second);
      it->second.clear();  // once, at the parent's place
    }
  }
  for (const auto& name : added) {
    if (set[name].find('=') != std::string::npos) out.push_back(set[name]);
  }
  return out;
}

}  // namespace

Result<Credentials> lookupUser(const std::string& user) {
  if (user.empty()) return makeError("no user named");
  std::vector<char> buffer(16384);
  passwd entry{};
  passwd* found = nullptr;
  int rc = getpwnam_r(user.c_str(), &entry, buffer.data(), buffer.size(), &found);
  if (rc == 0 && found == nullptr && user.find_first_not_of("0123456789") == std::string::npos &&
      user.size() < 10) {
    rc = getpwuid_r(static_cast<uid_t>(std::stoul(user)), &entry, buffer.data(), buffer.size(), &found);
  }
  if (rc != 0) return makeError("user " + user + ": " + std::strerror(rc));
  if (found == nullptr) return makeError("no user " + user + " on this host (useradd --system " + user + ")");
  if (found->pw_uid == 0) return makeError("user " + user + " is root: name an unprivileged user");
  Credentials c;
  c.user = found->pw_name;
  c.uid = found->pw_uid;
  c.gid = found->pw_gid;
  c.home = found->pw_dir ? found->pw_dir : "/";
  int count = 64;
  std::vector<gid_t> groups(static_cast<size_t>(count));
  if (getgrouplist(found->pw_name, found->pw_gid, groups.data(), &count) < 0) {
    groups.resize(static_cast<size_t>(count));
    if (getgrouplist(found->pw_name, found->pw_gid, groups.data(), &count) < 0) {
      return makeError("user " + user + ": cannot list its groups");
    }
  }
  groups.resize(static_cast<size_t>(count));
  for (gid_t g : groups) {
    if (g == 0) return makeError("user " + user + " is in group root (0): name an unprivileged user");
  }
  c.groups = std::move(groups);
  return c;
}

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

  std::vector<char*> argv;
  for (const auto& a : options.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  std::string out = options.stdoutPath.empty() ? "/dev/null" : options.stdoutPath;
  std::vector<std::string> environment;
  std::vector<char*> envp;
  if (!options.environment.empty()) {
    environment = mergedEnvironment(options.environment);
    for (auto& e : environment) envp.push_back(e.data());
    envp.push_back(nullptr);
  }
  auto start = std::chrono::steady_clock::now();
  auto spawned = spawnProcess(argv, {out, errPipe[1], true, -1, 3, envp.empty() ? environ : envp.data(),
                                     options.runAs ? &*options.runAs : nullptr});
  close(errPipe[1]);
  if (!spawned) {
    close(errPipe[0]);
    return makeError("cannot start " + options.argv[0] + ": " + spawned.error());
  }
  pid_t pid = *spawned;

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
  // Asked to end (shouldTerminate): SIGTERM now, SIGKILL after the grace period.
  bool terminating = false, terminateKilled = false;
  std::chrono::steady_clock::time_point terminateKillAt;
  auto checkStop = [&] {
    if (!stopped && options.shouldStop && options.shouldStop()) {
      stopped = true;
      kill(-pid, SIGKILL);
    }
    if (!terminating && options.shouldTerminate && options.shouldTerminate()) {
      terminating = true;
      result.terminated = true;
      terminateKillAt = std::chrono::steady_clock::now() + options.grace;
      kill(-pid, SIGTERM);
    }
    if (terminating && !terminateKilled && std::chrono::steady_clock::now() >= terminateKillAt) {
      terminateKilled = true;
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

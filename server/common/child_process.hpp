// Runs a capture (or any command) as a child process with a deadline, so that
// a crash, a hang, a lost device or an out-of-memory kill ends only the child.
#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <sys/types.h>

#include "common/result.hpp"

namespace tally::jobs {

// A user a child process runs as (tallyd serve --run-as): set between fork and
// exec, supplementary groups first, then the group, then the user.
struct Credentials {
  std::string user;
  uid_t uid = 0;
  gid_t gid = 0;
  std::vector<gid_t> groups;  // supplementary, from /etc/group
  std::string home;
};

// The user named `user` (or a number), from the password database. Refuses
// root (uid 0): running as root is what --run-as is there to avoid.
Result<Credentials> lookupUser(const std::string& user);

struct ChildOptions {
  std::vector<std::string> argv;          // argv[0] is the program path
  std::chrono::milliseconds deadline{0};  // 0: none; then SIGTERM, and SIGKILL after `grace`
  std::chrono::milliseconds grace{2000};
  std::string stdoutPath;                 // where the child's stdout goes ("" = /dev/null)
  // Called with each line the child writes to stderr (progress, errors).
  std::function<void(const std::string&)> onStderrLine;
  size_t stderrTailBytes = 4096;          // kept for the failure reason
  // Polled about every 200 ms; true kills the child's process group (SIGKILL),
  // e.g. when its job was cancelled. Empty: never.
  std::function<bool()> shouldStop;
  // Polled like shouldStop; true asks the child to end: SIGTERM to its
  // process group, then SIGKILL after `grace` (e.g. an application whose
  // output has been written). Empty: never.
  std::function<bool()> shouldTerminate;
  // "NAME=VALUE" entries set in the child's environment over the parent's
  // (a later entry of the same name wins; a bare "NAME" removes it). Empty:
  // the parent's environment as it is.
  std::vector<std::string> environment;
  // Run as this user (the caller must be root); nullopt: as this process.
  std::optional<Credentials> runAs;
};

struct ChildResult {
  enum class End { Exited, Signaled, TimedOut };
  End end = End::Exited;
  int exitCode = -1;   // when Exited
  int signal = 0;      // when Signaled (or the signal that ended a timed-out child)
  std::string stderrTail;
  std::chrono::milliseconds elapsed{0};
  bool terminated = false;  // shouldTerminate asked it to end (its end is then how it took that)

  bool ok() const { return end == End::Exited && exitCode == 0; }
  // "exited with status 3: <last stderr line>", "killed by signal 11 (SIGSEGV)",
  // "killed by signal 9 (SIGKILL: out of memory?)", "timed out after 30 s".
  std::string reason() const;
};

// Fails only if the child cannot be started (the program is missing, fork fails).
// The child is killed (SIGKILL) when the thread that called runChild ends,
// even by kill -9 of the whole process: call it from a thread that lives at
// least as long as the child should.
Result<ChildResult> runChild(const ChildOptions& options);

// How spawnProcess starts a program (what runChild uses, for a caller that
// keeps the child itself, such as an X server for an application's capture).
struct SpawnOptions {
  std::string stdoutPath;       // "" : /dev/null
  int stderrFd = -1;            // -1: the stdout file
  bool ownProcessGroup = true;  // false: the caller's group (its group's kill reaches the child)
  int passFd = -1;              // a descriptor the child gets as passAs (e.g. Xvfb's -displayfd)
  int passAs = 3;
  char** envp = nullptr;        // nullptr: this process's environment
  const Credentials* runAs = nullptr;  // nullptr: this process's user
};
// fork + exec with PR_SET_PDEATHSIG (the child dies with its parent, even on
// kill -9); stdin is /dev/null. An exec failure is the error, with its errno's
// text, as is a failure to become options.runAs (the child never execs then).
Result<pid_t> spawnProcess(const std::vector<char*>& argv, const SpawnOptions& options);

}  // namespace tally::jobs

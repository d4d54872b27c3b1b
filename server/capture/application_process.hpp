// The processes around a captured application: the capture's temporary
// folder, an X server of its own (Xvfb), and how the application ended, in
// the words of the capture's error messages. Used by application.cpp.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <utility>

#include <sys/types.h>

#include "common/child_process.hpp"
#include "common/result.hpp"

namespace tally::capture::detail {

// A temporary folder of the capture's own (the layer's output, Xvfb's log), removed at the end.
struct TempDir {
  std::filesystem::path path;
  // Under `root`, or the system's temporary folder where it is empty.
  static Result<TempDir> make(std::filesystem::path root);
  TempDir(std::filesystem::path p) : path(std::move(p)) {}  // NOLINT(google-explicit-constructor)
  TempDir(TempDir&& other) noexcept : path(std::exchange(other.path, {})) {}
  TempDir(const TempDir&) = delete;
  ~TempDir();
};

// An X server of the capture's own: Xvfb on the first free display
// (-displayfd), stopped (SIGTERM, then SIGKILL) when this is destroyed. It
// dies with tallyd even on kill -9 (PR_SET_PDEATHSIG) and shares tallyd's
// process group, so a cancelled job's kill reaches it too.
class XServer {
 public:
  // Xvfb's stdout and stderr go to `log`, whose last lines a failure quotes.
  static Result<std::unique_ptr<XServer>> start(const std::filesystem::path& log);
  ~XServer();
  XServer(const XServer&) = delete;
  XServer& operator=(const XServer&) = delete;

  int display() const { return display_; }

 private:
  explicit XServer(pid_t pid) : pid_(pid) {}
  pid_t pid_ = 0;
  int display_ = -1;
};

// How the application ended, as what "the application ..." did: "exited with
// status 0", "was killed by signal 11 (SIGSEGV)", "was stopped by tallyd
// (SIGTERM) once the output was written".
std::string endingOf(const jobs::ChildResult& r);

// The message, then the last lines of the application's stderr (or that it wrote none).
std::string withStderr(std::string message, const jobs::ChildResult& r);

}  // namespace tally::capture::detail

#include "capture/application_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <system_error>
#include <thread>
#include <vector>

#include "capture/spec.hpp"

namespace tally::capture::detail {
namespace fs = std::filesystem;

namespace {

// The last `count` non-empty lines of a stderr tail, joined by " | ", each
// shortened: one line for an error message.
std::string lastLines(const std::string& tail, size_t count = 3) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start < tail.size()) {
    size_t end = tail.find('\n', start);
    std::string line = tail.substr(start, end == std::string::npos ? std::string::npos : end - start);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    if (!line.empty()) lines.push_back(line.size() > 200 ? line.substr(0, 197) + "..." : line);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  std::string out;
  for (size_t i = lines.size() > count ? lines.size() - count : 0; i < lines.size(); ++i) {
    out += (out.empty() ? "" : " | ") + lines[i];
  }
  return out;
}

std::string readTail(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return text.size() > 4096 ? text.substr(text.size() - 4096) : text;
}

}  // namespace

Result<TempDir> TempDir::make(fs::path root) {
  std::error_code ec;
  if (root.empty()) root = fs::temp_directory_path(ec);
  if (ec || root.empty()) root = "/tmp";
  std::string pattern = (root / "tally-app-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) return makeError("cannot create a folder under " + root.string() + ": " + std::strerror(errno));
  return TempDir{pattern};
}

TempDir::~TempDir() {
  std::error_code ec;
  if (!path.empty()) fs::remove_all(path, ec);
}

Result<std::unique_ptr<XServer>> XServer::start(const fs::path& log) {
  const char* pathEnv = std::getenv("PATH");
  std::string program = findOnPath("Xvfb", pathEnv ? pathEnv : "");
  if (program.empty()) return makeError("Xvfb is not on $PATH (Debian: apt install xvfb)");
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return makeError(std::string("pipe: ") + std::strerror(errno));
  constexpr int kDisplayFd = 3;
  std::string displayFd = std::to_string(kDisplayFd), logPath = log.string();
  std::vector<std::string> args = {program, "-displayfd", displayFd, "-screen", "0", "1280x1024x24", "-nolisten", "tcp"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  // In tallyd's process group (see above); its stdout and stderr go to the log.
  auto spawned = jobs::spawnProcess(argv, {logPath, -1, false, fds[1], kDisplayFd, nullptr});
  if (!spawned) {
    close(fds[0]);
    close(fds[1]);
    return makeError("Xvfb: " + spawned.error());
  }
  const pid_t pid = *spawned;
  close(fds[1]);
  auto server = std::unique_ptr<XServer>(new XServer(pid));
  // The display number, one line, once the server accepts connections.
  std::string number;
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  bool ended = false;
  while (!ended && number.find('\n') == std::string::npos) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd p{fds[0], POLLIN, 0};
    int ready = poll(&p, 1, static_cast<int>(left.count()));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) break;
    char buffer[64];
    ssize_t n = read(fds[0], buffer, sizeof buffer);
    if (n <= 0) {
      ended = true;
    } else {
      number.append(buffer, static_cast<size_t>(n));
    }
  }
  close(fds[0]);
  size_t used = 0;
  int display = -1;
  try {
    display = std::stoi(number, &used);
  } catch (const std::exception&) {
    display = -1;
  }
  if (display < 0) {
    server.reset();  // stops it, if it still runs
    std::string why = lastLines(readTail(log), 2);
    return makeError(std::string(ended ? "Xvfb exited" : "Xvfb gave no display within 15 s") +
                     (why.empty() ? "" : ": " + why));
  }
  server->display_ = display;
  return server;
}

XServer::~XServer() {
  if (pid_ <= 0) return;
  kill(pid_, SIGTERM);
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  int status = 0;
  while (waitpid(pid_, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() >= deadline) {
      kill(pid_, SIGKILL);
      waitpid(pid_, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

std::string endingOf(const jobs::ChildResult& r) {
  using End = jobs::ChildResult::End;
  if (r.end == End::TimedOut) return "timed out after " + std::to_string(r.elapsed.count() / 1000) + " s";
  if (r.terminated) {
    if (r.end == End::Exited) return "exited with status " + std::to_string(r.exitCode) + " when asked to stop (SIGTERM)";
    if (r.signal == SIGKILL) return "was killed by tallyd (SIGKILL): it did not exit on SIGTERM";
    return "was stopped by tallyd (SIGTERM) once the output was written";
  }
  if (r.end == End::Exited) return "exited with status " + std::to_string(r.exitCode);
  jobs::ChildResult quiet = r;
  quiet.stderrTail.clear();
  return "was " + quiet.reason();  // "was killed by signal 11 (SIGSEGV)"
}

std::string withStderr(std::string message, const jobs::ChildResult& r) {
  std::string tail = lastLines(r.stderrTail);
  return tail.empty() ? message + "; it wrote nothing on stderr" : message + "; its stderr ended: " + tail;
}

}  // namespace tally::capture::detail

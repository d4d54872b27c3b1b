// The harness of the `tallyd serve` end-to-end tests: a real daemon (child
// process) on 127.0.0.1 with an ephemeral port and a temp database, requests
// through cpp-httplib, and the capture specs the tests share.
// TALLYD_PATH (the tallyd binary) comes from the test's CMake target.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include "proc_file.hpp"

extern char** environ;

namespace tally::service::test {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

struct Reply {
  int status = 0;  // 0: no response (connection failed or timed out)
  std::string body, contentType;
  json j() const { return json::parse(body, nullptr, false); }
};

inline std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}


// A `tallyd serve` child; its stdout (the address line) goes to a file.
class Daemon {
 public:
  Daemon(fs::path dir, fs::path db, std::vector<std::string> extra = {})
      : dir_(std::move(dir)), db_(std::move(db)), extra_(std::move(extra)) {}
  ~Daemon() {
    stop(SIGKILL);
    killOrphans();
  }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  bool start() {
    fs::path out = dir_ / ("serve-" + std::to_string(++starts_) + ".out");
    std::vector<std::string> args = {TALLYD_PATH, "serve", "--db", db_.string(), "--port", "0"};
    args.insert(args.end(), extra_.begin(), extra_.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                     0644);
    // Temp files of the worker (and thus its capture children's command lines) live under dir_.
    std::vector<std::string> env;
    for (char** e = environ; *e; ++e) {
      if (std::string(*e).rfind("TMPDIR=", 0) != 0) env.push_back(*e);
    }
    env.push_back("TMPDIR=" + tmp().string());
    fs::create_directories(tmp());
    std::vector<char*> envp;
    for (auto& e : env) envp.push_back(e.data());
    envp.push_back(nullptr);
    int rc = posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) return false;
    auto deadline = std::chrono::steady_clock::now() + 30s;
    while (std::chrono::steady_clock::now() < deadline) {
      std::string text = slurp(out);
      size_t at = text.find("http://127.0.0.1:");
      if (at != std::string::npos && text.find("/\n", at) != std::string::npos) {
        port_ = std::atoi(text.c_str() + at + 17);
        return port_ > 0;
      }
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = 0;
        return false;
      }
      std::this_thread::sleep_for(50ms);
    }
    return false;
  }

  // Returns the exit status (or 128 + signal).
  int stop(int sig = SIGTERM) {
    if (pid_ <= 0) return -1;
    kill(pid_, sig);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = 0;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

  // Sends `sig` and waits at most `timeout` for the daemon to exit: its exit
  // status (or 128 + signal), or -1 when it was still running (it is then
  // killed with SIGKILL, so that a test fails instead of hanging).
  int stopWithin(std::chrono::milliseconds timeout, int sig = SIGTERM) {
    if (pid_ <= 0) return -1;
    kill(pid_, sig);
    auto deadline = std::chrono::steady_clock::now() + timeout;
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() >= deadline) {
        stop(SIGKILL);
        return -1;
      }
      std::this_thread::sleep_for(10ms);
    }
    pid_ = 0;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

  // Capture children of this daemon that are still running (zombies waiting
  // for whoever adopted them do not count): the worker names their temp files
  // under tmp(), and they appear on the command line.
  std::vector<pid_t> runningJobChildren() const {
    std::vector<pid_t> found;
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator("/proc", ec)) {
      std::string name = entry.path().filename().string();
      if (name.find_first_not_of("0123456789") != std::string::npos) continue;
      if (tally::test::readProcFile(entry.path() / "cmdline").find(tmp().string() + "/tally-job-") == std::string::npos) continue;
      std::string stat = tally::test::readProcFile(entry.path() / "stat");
      size_t paren = stat.rfind(')');
      if (paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] == 'Z') continue;
      found.push_back(std::stoi(name));
    }
    return found;
  }

  // Polls (bounded) until no capture child of this daemon runs; true if none does.
  bool waitNoJobChildren(std::chrono::milliseconds timeout = 5000ms) const {
    auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!runningJobChildren().empty()) {
      if (std::chrono::steady_clock::now() >= deadline) return false;
      std::this_thread::sleep_for(20ms);
    }
    return true;
  }

  // So that nothing outlives a failed test.
  void killOrphans() {
    for (pid_t pid : runningJobChildren()) kill(pid, SIGKILL);
  }

  // Requests then carry "Authorization: Bearer <token>" ("": none).
  void setToken(std::string token) { token_ = std::move(token); }

  Reply request(const std::string& method, const std::string& path, const std::string& body = {},
                const std::string& idempotencyKey = {}) {
    httplib::Client client("127.0.0.1", port_);
    client.set_read_timeout(10, 0);
    httplib::Headers headers;
    if (!idempotencyKey.empty()) headers.emplace("Idempotency-Key", idempotencyKey);
    if (!token_.empty()) headers.emplace("Authorization", "Bearer " + token_);
    httplib::Result res = method == "GET"    ? client.Get(path.c_str(), headers)
                          : method == "POST" ? client.Post(path.c_str(), headers, body, "application/json")
                          : method == "PATCH" ? client.Patch(path.c_str(), headers, body, "application/json")
                                              : client.Delete(path.c_str(), headers);
    Reply r;
    if (!res) return r;
    r.status = res->status;
    r.body = res->body;
    r.contentType = res->get_header_value("Content-Type");
    return r;
  }

  // Polls until the capture is done, failed or cancelled.
  json waitFinished(int64_t id, std::chrono::seconds timeout = 120s) {
    auto deadline = std::chrono::steady_clock::now() + timeout;
    json job;
    while (std::chrono::steady_clock::now() < deadline) {
      Reply r = request("GET", "/api/captures/" + std::to_string(id));
      job = r.j();
      if (r.status == 200) {
        std::string s = job.value("status", "");
        if (s == "done" || s == "failed" || s == "cancelled") return job;
      }
      std::this_thread::sleep_for(200ms);
    }
    return job;
  }

  // Polls until the capture is mid-way (running, and its child has reported
  // progress) or has left the queue otherwise; returns the job as last seen.
  json waitProgress(int64_t id, std::chrono::seconds timeout = 30s) {
    auto deadline = std::chrono::steady_clock::now() + timeout;
    json job;
    while (std::chrono::steady_clock::now() < deadline) {
      job = request("GET", "/api/captures/" + std::to_string(id)).j();
      std::string status = job.value("status", "");
      if (status != "queued" && (status != "running" || job["progress"]["done"].get<int64_t>() > 0)) break;
      std::this_thread::sleep_for(20ms);
    }
    return job;
  }

  fs::path tmp() const { return dir_ / "tmp"; }
  int port() const { return port_; }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }

 private:
  fs::path dir_, db_;
  std::vector<std::string> extra_;
  std::string token_;
  pid_t pid_ = 0;
  int port_ = 0;
  int starts_ = 0;
};

inline fs::path makeTempDir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / (name + "-" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A token file (mode 600) with read, capture and application tokens, for a
// daemon that runs applications (docs/operating.md, "Security model").
struct ApplicationTokens {
  std::string read = "r3ad-0123456789abcdefghijklmnopqrstuv";
  std::string capture = "c4pture-0123456789abcdefghijklmnopqrst";
  std::string application = "app1ication-0123456789abcdefghijklmnop";
  fs::path file;
};
inline ApplicationTokens writeApplicationTokens(const fs::path& dir) {
  ApplicationTokens t;
  t.file = dir / "tokens";
  std::ofstream(t.file) << "read=" << t.read << "\ncapture=" << t.capture << "\napplication=" << t.application
                        << "\n";
  fs::permissions(t.file, fs::perms::owner_read | fs::perms::owner_write);
  return t;
}

// The flags of a daemon that runs applications from `roots` with the spec env
// names `env` allowed: as root (CI), they run as nobody.
inline std::vector<std::string> applicationFlags(const ApplicationTokens& tokens,
                                                 const std::vector<fs::path>& roots,
                                                 const std::vector<std::string>& env = {}) {
  std::vector<std::string> flags = {"--allow-applications", "--token-file", tokens.file.string()};
  for (const auto& root : roots) flags.insert(flags.end(), {"--application-root", root.string()});
  for (const auto& name : env) flags.insert(flags.end(), {"--application-env", name});
  if (geteuid() == 0) flags.insert(flags.end(), {"--run-as", "nobody"});
  return flags;
}

// 2 renderers x 1 camera at 64x36, 2 frames: the quickest capture with two runs.
inline json tinySpec() {
  return {{"renderers", {"forward", "deferred"}},
          {"scenes", {{{"name", "planes"}, {"layers", 2}}}},
          {"resolutions", {{64, 36}}},
          {"cameras", {{{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}}}},
          {"frames", 2},
          {"lights", 4}};
}

// 2 renderers x 3 resolutions x 10 auto cameras = 6 runs of 10 samples of 8
// frames: on lavapipe it runs for seconds, long enough to be caught running.
inline constexpr int kLongSpecRuns = 6;
inline constexpr int kLongSpecSamplesPerRun = 10;
inline json longSpec() {
  json spec = tinySpec();
  spec["cameras"] = "auto";
  spec["resolutions"] = {{64, 36}, {96, 54}, {128, 72}};
  spec["frames"] = 8;
  return spec;
}

}  // namespace tally::service::test

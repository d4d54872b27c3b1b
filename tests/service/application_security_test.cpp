// Who may run an application through the daemon, and what it refuses
// (docs/operating.md, "Security model"): `tallyd serve --allow-applications`
// refuses to start without an application token, without an application
// root, as root without --run-as, with a loader variable allowed; another
// local user posting `/bin/sh -c "id > pwned"` runs nothing, with no token,
// the read token, the capture token, or even the application token; refusals
// name their field; applications run as the --run-as user. tests/capture/
// fake_app.sh stands in for the application; no GPU is needed.
#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "daemon.hpp"
#include "common/child_process.hpp"

namespace {
using namespace tally::service::test;

const char* kShell = "/bin/sh";

class ApplicationSecurity : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-application-security-test");
    fs::permissions(dir_, fs::perms(0755));
    fs::create_directories(dir_ / "layer");
    std::ofstream(dir_ / "layer" / "VkLayer_tally_counters.json") << "{}";
    setenv("TALLY_LAYER_PATH", (dir_ / "layer").string().c_str(), 1);
    // Where a command, had it run as anyone, could have written.
    fs::create_directories(openDir());
    fs::permissions(openDir(), fs::perms(01777));
    tokens_ = writeApplicationTokens(dir_);
    daemon_ = new Daemon(dir_, dir_ / "tally.db", applicationFlags(tokens_, {root()}, {"FAKE_APP_*"}));
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
  }
  static void TearDownTestSuite() {
    if (daemon_) {
      EXPECT_EQ(daemon_->stop(SIGTERM), 0);
    }
    delete daemon_;
    daemon_ = nullptr;
    unsetenv("TALLY_LAYER_PATH");
    fs::remove_all(dir_);
  }

  static fs::path openDir() { return dir_ / "open"; }
  static fs::path root() { return fs::path(FAKE_APP).parent_path(); }
  static fs::path pwned() { return openDir() / "pwned"; }
  static json shellSpec() {
    return {{"application", {{"command", {kShell, "-c", "id > " + pwned().string()}}}}};
  }

  // `tallyd serve` with these flags: its exit status and stderr (it should
  // refuse before it binds; a daemon that starts is stopped at the deadline).
  static std::pair<int, std::string> serve(std::vector<std::string> flags) {
    tally::jobs::ChildOptions child;
    child.argv = {TALLYD_PATH, "serve", "--db", (dir_ / "refused.db").string(), "--port", "0"};
    child.argv.insert(child.argv.end(), flags.begin(), flags.end());
    child.deadline = std::chrono::seconds(10);
    auto ran = tally::jobs::runChild(child);
    EXPECT_TRUE(ran.ok());
    if (!ran.ok()) return {-1, ""};
    return {ran->end == tally::jobs::ChildResult::End::Exited ? ran->exitCode : -1, ran->stderrTail};
  }

  static size_t jobCount() {
    daemon_->setToken(tokens_.read);
    Reply r = daemon_->request("GET", "/api/captures?limit=500");
    EXPECT_EQ(r.status, 200) << r.body;
    return r.status == 200 ? r.j()["captures"].size() : 0;
  }

  static inline fs::path dir_;
  static inline ApplicationTokens tokens_;
  static inline Daemon* daemon_ = nullptr;
};

TEST_F(ApplicationSecurity, ServeRefusesUnsafeSetups) {
  const std::string rootFlag = root().string();
  fs::path noApplication = dir_ / "tokens-no-application";
  std::ofstream(noApplication) << "read=" << tokens_.read << "\ncapture=" << tokens_.capture << "\n";
  fs::permissions(noApplication, fs::perms::owner_read | fs::perms::owner_write);
  const std::vector<std::string> runAs =
      geteuid() == 0 ? std::vector<std::string>{"--run-as", "nobody"} : std::vector<std::string>{};
  auto with = [&](std::vector<std::string> flags) {
    flags.insert(flags.end(), runAs.begin(), runAs.end());
    return flags;
  };
  struct Case {
    std::vector<std::string> flags;
    std::string mention;
  };
  std::vector<Case> cases = {
      {with({"--allow-applications", "--application-root", rootFlag}),
       "--allow-applications needs --token-file"},
      {with({"--allow-applications", "--token-file", noApplication.string(), "--application-root", rootFlag}),
       "has no application=<token> line"},
      {with({"--allow-applications", "--token-file", tokens_.file.string()}),
       "at least one --application-root"},
      {with(
           {"--allow-applications", "--token-file", tokens_.file.string(), "--application-root", "relative"}),
       "must be an absolute path"},
      {with({"--allow-applications", "--token-file", tokens_.file.string(), "--application-root", FAKE_APP}),
       "not a folder"},
      {with({"--allow-applications", "--token-file", tokens_.file.string(), "--application-root", rootFlag,
             "--application-env", "LD_PRELOAD"}),
       "--application-env LD_PRELOAD"},
      {with({"--allow-applications", "--token-file", tokens_.file.string(), "--application-root", rootFlag,
             "--application-env", "VK_INSTANCE_LAYERS"}),
       "VK_*LAYER*"},
      {{"--application-root", rootFlag}, "go with --allow-applications"},
  };
  if (geteuid() == 0) {
    cases.push_back(
        {{"--allow-applications", "--token-file", tokens_.file.string(), "--application-root", rootFlag},
         "refusing to run applications as root: give --run-as USER"});
    cases.push_back({{"--allow-applications", "--token-file", tokens_.file.string(), "--application-root",
                      rootFlag, "--run-as", "root"},
                     "is root"});
  } else {
    cases.push_back({{"--allow-applications", "--token-file", tokens_.file.string(), "--application-root",
                      rootFlag, "--run-as", "nobody"},
                     "drop --run-as"});
  }
  for (const auto& c : cases) {
    auto [rc, err] = serve(c.flags);
    EXPECT_EQ(rc, 1) << c.mention << ": " << err;
    EXPECT_NE(err.find(c.mention), std::string::npos) << err;
  }
}

// The attack: another local user posts the shell command. Without a
// token: 401; with the read or the capture token: 403; even with the
// application token: 400, as /bin/sh is outside the application roots. The
// token file is not theirs to read. No job is queued, and nothing runs.
TEST_F(ApplicationSecurity, AnotherLocalUserCannotRunACommand) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to act as another user (CI runs as root)";
  const passwd* nobody = getpwnam("nobody");
  ASSERT_NE(nobody, nullptr);
  const uid_t uid = nobody->pw_uid;
  const gid_t gid = nobody->pw_gid;
  const size_t before = jobCount();
  const std::string body = shellSpec().dump();
  const int port = daemon_->port();

  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(fds[0]);
    if (setgroups(0, nullptr) != 0 || setgid(gid) != 0 || setuid(uid) != 0 || getuid() != uid) _exit(2);
    std::ostringstream out;
    // The token file: unreadable to another user.
    std::ifstream tokens(tokens_.file);
    out << (tokens.is_open() ? "readable" : "unreadable");
    for (const std::string& token : {std::string(), tokens_.read, tokens_.capture, tokens_.application}) {
      httplib::Client client("127.0.0.1", port);
      client.set_read_timeout(10, 0);
      httplib::Headers headers;
      if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
      auto res = client.Post("/api/captures", headers, body, "application/json");
      out << " " << (res ? res->status : 0);
      if (res && res->status == 400) {
        out << " " << json::parse(res->body, nullptr, false)["error"].value("field", "");
      }
    }
    const std::string text = out.str();
    ssize_t ignored = write(fds[1], text.data(), text.size());
    (void)ignored;
    _exit(0);
  }
  close(fds[1]);
  std::string seen;
  char buffer[256];
  for (ssize_t n; (n = read(fds[0], buffer, sizeof buffer)) > 0;) seen.append(buffer, size_t(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the other user's process failed: " << status;
  EXPECT_EQ(seen, "unreadable 401 403 403 400 application.command[0]");

  EXPECT_EQ(jobCount(), before) << "a job was queued";
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // a worker would have started by now
  EXPECT_FALSE(fs::exists(pwned())) << "the command ran";
  EXPECT_TRUE(daemon_->runningJobChildren().empty());
}

// Each refusal names its field, over HTTP, with the application token.
TEST_F(ApplicationSecurity, RefusalsNameTheField) {
  fs::create_directories(dir_ / "links");
  fs::create_symlink("/etc/shadow", dir_ / "links" / "shadow.gfxr");
  const std::string app = FAKE_APP;
  struct Case {
    json spec;
    std::string field;
  };
  const std::vector<Case> cases = {
      {shellSpec(), "application.command[0]"},
      {{{"application", {{"command", {"sh", "-c", "id"}}}}}, "application.command[0]"},
      {{{"replay", "/etc/shadow"}}, "replay"},
      {{{"replay", (dir_ / "links" / "shadow.gfxr").string()}}, "replay"},
      {{{"application", {{"command", {app}}, {"env", {{"LD_PRELOAD", "/tmp/x.so"}}}}}},
       "application.env.LD_PRELOAD"},
      {{{"application", {{"command", {app}}, {"env", {{"PATH", openDir().string()}}}}}},
       "application.env.PATH"},
      {{{"application", {{"command", {app}}, {"env", {{"VK_LOADER_LAYERS_ENABLE", "*"}}}}}},
       "application.env.VK_LOADER_LAYERS_ENABLE"},
      {{{"application", {{"command", {app}}, {"env", {{"PYTHONPATH", openDir().string()}}}}}},
       "application.env.PYTHONPATH"},
  };
  daemon_->setToken(tokens_.application);
  const size_t before = jobCount();
  daemon_->setToken(tokens_.application);
  for (const auto& c : cases) {
    Reply r = daemon_->request("POST", "/api/captures", c.spec.dump());
    EXPECT_EQ(r.status, 400) << c.spec.dump() << ": " << r.body;
    EXPECT_EQ(r.j()["error"].value("field", ""), c.field) << r.body;
  }
  EXPECT_EQ(jobCount(), before);
}

// What does run runs as the --run-as user (as the daemon's own user when it is not root).
TEST_F(ApplicationSecurity, ApplicationsRunAsTheRunAsUser) {
  const fs::path record = openDir() / "record.txt";
  json spec = {{"application",
                {{"command", {FAKE_APP}},
                 {"frames", 2},
                 {"env", {{"FAKE_APP_MODE", "ok"}, {"FAKE_APP_RECORD", record.string()}}}}}};
  daemon_->setToken(tokens_.application);
  Reply posted = daemon_->request("POST", "/api/captures", spec.dump());
  ASSERT_EQ(posted.status, 202) << posted.body;
  json job = daemon_->waitFinished(posted.j()["id"].get<int64_t>(), std::chrono::seconds(60));
  ASSERT_EQ(job.value("status", ""), "done") << job.dump();
  std::ifstream in(record);
  std::string line, runUid;
  while (std::getline(in, line)) {
    if (line.rfind("RUN_UID=", 0) == 0) runUid = line.substr(8);
  }
  const uid_t expected = geteuid() == 0 ? getpwnam("nobody")->pw_uid : geteuid();
  EXPECT_EQ(runUid, std::to_string(expected));
}

}  // namespace

// Applications through the daemon: `tallyd serve --allow-applications` (its
// application token, tests/capture as the application root, as nobody when
// the test runs as root) with
// tests/capture/fake_app.sh standing in for the application and a manifest
// folder of the test's own ($TALLY_LAYER_PATH, inherited by the capture
// children). A crash, an early exit, a hang and an incomplete output each fail
// their job with the reason while the daemon keeps serving; a later capture
// through `tally capture --spec` succeeds and `tally show` displays it. No
// Vulkan device is needed.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "daemon.hpp"
#include "common/child_process.hpp"

namespace {
using namespace tally::service::test;

class ApplicationService : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = makeTempDir("tally-application-service-test");
    fs::create_directories(dir_ / "layer");
    std::ofstream(dir_ / "layer" / "VkLayer_tally_counters.json") << "{}";
    // The daemon copies this process's environment: its capture children find the manifest here.
    setenv("TALLY_LAYER_PATH", (dir_ / "layer").string().c_str(), 1);
    tokens_ = writeApplicationTokens(dir_);
    daemon_ = new Daemon(dir_, dir_ / "tally.db",
                         applicationFlags(tokens_, {fs::path(FAKE_APP).parent_path()}, {"FAKE_APP_*"}));
    ASSERT_TRUE(daemon_->start()) << "tallyd serve did not start";
    daemon_->setToken(tokens_.application);
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

  static json appSpec(const std::string& mode, json extra = json::object()) {
    json app = {{"command", {FAKE_APP}}, {"frames", 3}, {"env", {{"FAKE_APP_MODE", mode}}}};
    app.update(extra);
    return {{"application", app}};
  }

  // Posts the spec and waits for its job to finish.
  static json run(const json& spec) {
    Reply posted = daemon_->request("POST", "/api/captures", spec.dump());
    EXPECT_EQ(posted.status, 202) << posted.body;
    if (posted.status != 202) return nullptr;
    return daemon_->waitFinished(posted.j()["id"].get<int64_t>(), std::chrono::seconds(60));
  }

  // The tally binary against the daemon.
  static tally::jobs::ChildResult tally(const std::vector<std::string>& args, const fs::path& out) {
    tally::jobs::ChildOptions child;
    child.argv = {TALLY_PATH, "--server", daemon_->url()};
    child.argv.insert(child.argv.end(), args.begin(), args.end());
    child.environment = {"TALLY_SERVER", "TALLY_TOKEN=" + tokens_.application};
    child.stdoutPath = out.string();
    child.deadline = std::chrono::seconds(60);
    auto r = tally::jobs::runChild(child);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error());
    return r.ok() ? *r : tally::jobs::ChildResult{};
  }

  static inline fs::path dir_;
  static inline ApplicationTokens tokens_;
  static inline Daemon* daemon_ = nullptr;
};

TEST_F(ApplicationService, FailuresEndOnlyTheirJob) {
  struct Case {
    std::string mode;
    json extra;
    std::string reason;
  };
  const std::vector<Case> cases = {
      {"segv", json::object(), "the application was killed by signal 11 (SIGSEGV) before the layer wrote its output"},
      {"exit1", json::object(), "the application exited with status 1 before the layer wrote its output"},
      {"hang", {{"timeout_s", 1}}, "the application did not deliver 3 frames within application.timeout_s (1 s)"},
      {"incomplete", {{"frames", 5}}, "only 2 of the 5 frames asked for arrived"},
  };
  for (const auto& c : cases) {
    json job = run(appSpec(c.mode, c.extra));
    EXPECT_EQ(job.value("status", ""), "failed") << c.mode << ": " << job.dump();
    const std::string error = job.value("error", "");
    EXPECT_NE(error.find(c.reason), std::string::npos) << c.mode << ": " << error;
    EXPECT_EQ(daemon_->request("GET", "/api/health").status, 200) << "the daemon stopped after " << c.mode;
    Reply runs = daemon_->request("GET", "/api/runs?capture=" + std::to_string(job["id"].get<int64_t>()));
    EXPECT_EQ(runs.j()["runs"].size(), 0u) << "a failed job stores no run";
  }
  // The crash's stderr reaches the job's error.
  json crashed = run(appSpec("segv"));
  EXPECT_NE(crashed.value("error", "").find("fake app: about to crash on request"), std::string::npos) << crashed.dump();
  EXPECT_TRUE(daemon_->waitNoJobChildren());
}

// After failures, a capture through the CLI (tally capture --spec) succeeds,
// and tally show displays its run: no cameras, screenshots or image error.
TEST_F(ApplicationService, CliCaptureAndShowAfterAFailure) {
  EXPECT_EQ(run(appSpec("exit1")).value("status", ""), "failed");
  fs::path spec = dir_ / "app.json";
  std::ofstream(spec) << appSpec("ok", {{"name", "cube"}, {"skip_frames", 4}}).dump();
  auto captured = tally({"capture", "--spec", spec.string()}, dir_ / "capture.out");
  ASSERT_TRUE(captured.ok()) << captured.reason() << "\n" << slurp(dir_ / "capture.out");

  Reply runs = daemon_->request("GET", "/api/runs?renderer=app:cube");
  ASSERT_EQ(runs.status, 200) << runs.body;
  ASSERT_EQ(runs.j()["runs"].size(), 1u) << runs.body;
  const int64_t id = runs.j()["runs"][0]["id"];
  Reply run = daemon_->request("GET", "/api/runs/" + std::to_string(id));
  ASSERT_EQ(run.status, 200);
  EXPECT_EQ(run.j()["sample_count"], 3);
  EXPECT_EQ(run.j()["notes"]["timing"], "instrumented");
  EXPECT_EQ(run.j()["passes"].size(), 2u);

  auto shown = tally({"show", std::to_string(id)}, dir_ / "show.out");
  ASSERT_TRUE(shown.ok()) << shown.reason();
  const std::string text = slurp(dir_ / "show.out");
  EXPECT_NE(text.find("app:cube"), std::string::npos) << text;
  EXPECT_NE(text.find("frame 4"), std::string::npos) << text;
  EXPECT_NE(text.find("frame 6"), std::string::npos) << text;
  EXPECT_NE(text.find("layer note: pipeline layout 0x20"), std::string::npos) << text;
}

}  // namespace

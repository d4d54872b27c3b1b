// `tallyd capture` on application specs, with tests/capture/fake_app.sh
// standing in for a Vulkan application under the layer (it reads the layer's
// environment and writes an output of the layer's shape, or misbehaves on
// request) and a manifest folder of the test's own ($TALLY_LAYER_PATH). The
// result is stored in a Store and served by the service's routes in-process.
// No Vulkan device is needed.
#include <gtest/gtest.h>
#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "api/router.hpp"
#include "capture/spec.hpp"
#include "common/paths.hpp"
#include "common/child_process.hpp"
#include "service/service.hpp"
#include "store/store.hpp"
#include "read_file.hpp"
#include "strict.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

// NAME=VALUE lines (the fake application's record) as a map.
std::map<std::string, std::string> record(const fs::path& path) {
  std::map<std::string, std::string> out;
  std::istringstream in(tally::test::readFile(path));
  for (std::string line; std::getline(in, line);) {
    size_t eq = line.find('=');
    if (eq != std::string::npos) out[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return out;
}

struct Capture {
  int rc = -1;
  std::string err;  // tallyd's stderr: progress lines, then the reason on failure
  json result;
  std::chrono::milliseconds elapsed{0};
  std::string lastLine() const {
    std::string e = err;
    while (!e.empty() && e.back() == '\n') e.pop_back();
    size_t nl = e.rfind('\n');
    return nl == std::string::npos ? e : e.substr(nl + 1);
  }
};

class ApplicationCapture : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string pattern = (fs::temp_directory_path() / "tally-apprun-XXXXXX").string();
    dir_ = mkdtemp(pattern.data());
    fs::create_directories(layerDir());
    std::ofstream(layerDir() / tally::kLayerManifest) << R"({"file_format_version": "1.2.0"})";
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path layerDir() const { return dir_ / "layer"; }

  // Runs `tallyd capture --spec` on the spec; `env` over the test's own
  // environment (TALLY_LAYER_PATH: the test's manifest folder unless given).
  Capture capture(const json& spec, std::vector<std::string> env = {}) {
    static int count = 0;
    const std::string n = std::to_string(++count);
    fs::path specPath = dir_ / ("spec-" + n + ".json"), out = dir_ / ("result-" + n + ".json");
    std::ofstream(specPath) << spec.dump();
    tally::jobs::ChildOptions child;
    child.argv = {TALLYD_PATH, "capture", "--spec", specPath.string(), "--out", out.string()};
    child.environment = {"TALLY_LAYER_PATH=" + layerDir().string()};
    child.environment.insert(child.environment.end(), env.begin(), env.end());
    child.deadline = 60s;
    child.stderrTailBytes = 1 << 16;
    auto ran = tally::jobs::runChild(child);
    Capture c;
    if (!ran) {
      ADD_FAILURE() << ran.error();
      return c;
    }
    c.rc = ran->end == tally::jobs::ChildResult::End::Exited ? ran->exitCode : -1;
    c.err = ran->stderrTail;
    c.elapsed = ran->elapsed;
    if (fs::exists(out)) c.result = json::parse(tally::test::readFile(out), nullptr, false);
    return c;
  }

  json appSpec(const std::string& mode, uint32_t frames = 3, json extra = json::object()) {
    json app = {{"command", {FAKE_APP, "--c", "100"}}, {"frames", frames},
                {"env", {{"FAKE_APP_MODE", mode}, {"FAKE_APP_RECORD", (dir_ / "record.txt").string()}}}};
    app.update(extra);
    return {{"application", app}};
  }

  fs::path dir_;
};

// The capture's result: one run, one sample per frame, the passes and
// resources the layer named; stored, and served by GET /api/runs/{id}.
TEST_F(ApplicationCapture, ResultStoredAndServed) {
  json spec = appSpec("ok", 3, {{"skip_frames", 2}});
  spec["application"]["env"]["MY_SETTING"] = "on and off";
  spec["counting"] = "exact";
  Capture c = capture(spec);
  ASSERT_EQ(c.rc, 0) << c.err;
  // Progress lines as the worker reads them.
  EXPECT_NE(c.err.find("[1/3] app:fake_app.sh: waiting for 3 frames after 2 skipped"), std::string::npos) << c.err;
  EXPECT_NE(c.err.find("[3/3] app:fake_app.sh: done, 3 frames"), std::string::npos) << c.err;

  // What the application was given.
  auto env = record(dir_ / "record.txt");
  EXPECT_EQ(env["VK_ADD_LAYER_PATH"], layerDir().string());
  EXPECT_EQ(env["VK_INSTANCE_LAYERS"], "VK_LAYER_TALLY_counters");
  EXPECT_EQ(env["VK_LOADER_LAYERS_ENABLE"], "VK_LAYER_TALLY_counters");
  EXPECT_EQ(env["TALLY_LAYER_FRAMES"], "3");
  EXPECT_EQ(env["TALLY_LAYER_SKIP_FRAMES"], "2");
  EXPECT_EQ(env["TALLY_LAYER_FRAME_SUBMITS"], "0");
  EXPECT_EQ(env["TALLY_LAYER_COUNTING"], "exact");
  EXPECT_NE(env["TALLY_LAYER_OUTPUT"], "");
  EXPECT_FALSE(fs::exists(env["TALLY_LAYER_OUTPUT"])) << "the capture's temporary folder is removed";
  EXPECT_EQ(env["MY_SETTING"], "on and off");
  EXPECT_EQ(env["ARGS"], "--c 100");

  const json& r = c.result;
  ASSERT_TRUE(r.is_object()) << c.err;
  EXPECT_EQ(r["device"]["name"], "Fake GPU");
  ASSERT_EQ(r["runs"].size(), 1u);
  const json& run = r["runs"][0];
  EXPECT_EQ(run["renderer"], "app:fakecube");
  EXPECT_EQ(run["scene"], std::string(FAKE_APP) + " --c 100");
  EXPECT_EQ(run["width"], 64);
  EXPECT_EQ(run["height"], 48);
  EXPECT_EQ(run["counting"], "exact");
  EXPECT_EQ(run["notes"]["timing"], "instrumented");
  EXPECT_EQ(run["notes"]["application_exit"], "exited with status 0");
  EXPECT_EQ(run["notes"]["uninstrumented_shaders"][0]["name"], "shader 0x11");
  ASSERT_EQ(run["samples"].size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const json& s = run["samples"][i];
    EXPECT_EQ(s["camera"]["frame"], 2 + i);
    ASSERT_EQ(s["passes"].size(), 2u);
    EXPECT_EQ(s["passes"][0]["name"], "render pass 0");
    EXPECT_EQ(s["passes"][1]["name"], "compute 1");
    EXPECT_EQ(s["passes"][1]["compute_invocations"], 128);
    EXPECT_DOUBLE_EQ(s["frame_ms"].get<double>(), 0.75);
    ASSERT_EQ(s["passes"][0]["resources"].size(), 3u);
    EXPECT_EQ(s["passes"][0]["resources"][0]["name"], "texture 0x1");
  }

  // Stored as any capture's result.
  fs::path db = dir_ / "tally.db";
  auto opened = tally::store::Store::open(db.string());
  ASSERT_TRUE(opened.ok()) << opened.error();
  auto& store = **opened;
  auto job = store.jobs().create(spec);
  ASSERT_TRUE(job.ok()) << job.error();
  auto ingested = store.runs().ingestCapture(job->job.id, r, {});
  ASSERT_TRUE(ingested.ok()) << ingested.error();
  EXPECT_EQ(*ingested, 1);

  // Served by the service's routes.
  tally::service::ServiceContext ctx;
  ctx.writer = &store;
  ctx.dbPath = db.string();
  ctx.rendererNames = {"forward"};
  tally::api::Router router;
  tally::service::addServiceRoutes(router, ctx);
  auto get = [&](const std::string& path) {
    tally::api::Request req;
    req.method = "GET";
    req.path = path.substr(0, path.find('?'));
    if (size_t q = path.find('?'); q != std::string::npos) {
      std::string key = path.substr(q + 1, path.find('=', q) - q - 1);
      req.query[key] = path.substr(path.find('=', q) + 1);
    }
    auto response = router.dispatch(req);
    EXPECT_EQ(response.status, 200) << path << ": " << response.json.dump();
    // The runs listing and a run answer their JSON as text (a raw application/json body).
    return response.isRaw() ? json::parse(response.bytes) : response.json;
  };
  json runs = get("/api/runs?capture=" + std::to_string(job->job.id));
  ASSERT_EQ(runs["runs"].size(), 1u) << runs.dump();
  const int64_t runId = runs["runs"][0]["id"];
  json served = get("/api/runs/" + std::to_string(runId));
  EXPECT_EQ(served["renderer"], "app:fakecube");
  EXPECT_EQ(served["variant"], "app:fakecube");
  EXPECT_EQ(served["device"], "Fake GPU");
  EXPECT_EQ(served["sample_count"], 3);
  EXPECT_EQ(served["width"], 64);
  EXPECT_EQ(served["counting"], "exact");
  EXPECT_EQ(served["notes"]["source"]["kind"], "application");
  EXPECT_EQ(served["notes"]["layer"]["name"], "VK_LAYER_TALLY_counters");
  EXPECT_TRUE(served["image_error"].is_null());
  EXPECT_TRUE(served["counter_headroom"].is_null());
  ASSERT_EQ(served["passes"].size(), 2u);
  EXPECT_EQ(served["passes"][0]["name"], "render pass 0");
  EXPECT_DOUBLE_EQ(served["passes"][0]["bytes"].get<double>(), 12288 + 2304 + 12288);
  ASSERT_EQ(served["resources"].size(), 3u);
  EXPECT_EQ(served["resources"][0]["name"], "swapchain");
  EXPECT_EQ(served["resources"][0]["format_bytes"], 12288);
  json samples = get("/api/runs/" + std::to_string(runId) + "/samples");
  ASSERT_EQ(samples["samples"].size(), 3u);
  EXPECT_EQ(samples["samples"][0]["camera"]["label"], "frame 2");
  EXPECT_TRUE(samples["samples"][0]["screenshot"].is_null());
  EXPECT_TRUE(samples["samples"][0]["image_error"].is_null());
  EXPECT_TRUE(samples["samples"][0]["sky_fraction"].is_null());
  json sample = get("/api/samples/" + std::to_string(samples["samples"][0]["id"].get<int64_t>()));
  EXPECT_EQ(sample["passes"][0]["resources"][2]["name"], "swapchain");
  EXPECT_EQ(sample["passes"][0]["resources"][2]["access"], "write");
}

// Each way an application can fail ends the capture with one line naming why.
TEST_F(ApplicationCapture, FailuresNameTheReason) {
  struct Case {
    std::string mode;
    json extra;
    std::vector<std::string> expected;  // each in tallyd's last stderr line
  };
  const std::vector<Case> cases = {
      {"segv", json::object(),
       {"the application was killed by signal 11 (SIGSEGV) before the layer wrote its output",
        "its stderr ended: fake app: drawing frame 1 | fake app: about to crash on request"}},
      {"exit1", json::object(),
       {"the application exited with status 1 before the layer wrote its output",
        "fake app: cannot open the window on request"}},
      {"hang", {{"timeout_s", 1}},
       {"the application did not deliver 3 frames within application.timeout_s (1 s) and was stopped",
        "fake app: hanging on request"}},
      {"incomplete", {{"frames", 5}},
       {"only 2 of the 5 frames asked for arrived", "complete: false", "the application exited with status 0"}},
      {"badjson", json::object(), {"the layer's output is not a valid JSON object"}},
      {"silent", json::object(),
       {"the application exited with status 0 before the layer wrote its output",
        "or the layer did not load: manifest " + (layerDir() / tally::kLayerManifest).string()}},
  };
  for (const auto& c : cases) {
    Capture r = capture(appSpec(c.mode, 3, c.extra));
    EXPECT_EQ(r.rc, 1) << c.mode << ": " << r.err;
    EXPECT_TRUE(r.result.is_null()) << c.mode << ": no result is written";
    const std::string line = r.lastLine();
    EXPECT_EQ(line.rfind("tallyd capture: ", 0), 0u) << c.mode << ": " << line;
    for (const auto& e : c.expected) EXPECT_NE(line.find(e), std::string::npos) << c.mode << ": " << line << "\n  expected: " << e;
  }
}

TEST_F(ApplicationCapture, NoLayerManifestFails) {
  fs::create_directories(dir_ / "empty");
  Capture c = capture(appSpec("ok"), {"TALLY_LAYER_PATH=" + (dir_ / "empty").string()});
  EXPECT_EQ(c.rc, 1);
  EXPECT_NE(c.lastLine().find("$TALLY_LAYER_PATH (" + (dir_ / "empty").string() + ") holds no VkLayer_tally_counters.json"),
            std::string::npos)
      << c.err;
}

// An application that keeps running once the output is written gets 2 s,
// then SIGTERM, then (ignoring it) SIGKILL 2 s later; its output stands.
TEST_F(ApplicationCapture, LingeringApplicationIsStopped) {
  json spec = appSpec("linger");
  spec["application"]["env"]["FAKE_APP_IGNORE_TERM"] = "1";
  Capture c = capture(spec);
  ASSERT_EQ(c.rc, 0) << c.err;
  EXPECT_GE(c.elapsed, 3500ms);  // not before its 2 s + 2 s; how much later depends on the machine's load
  EXPECT_EQ(c.result["runs"][0]["notes"]["application_exit"], "was killed by tallyd (SIGKILL): it did not exit on SIGTERM");
  EXPECT_EQ(c.result["runs"][0]["samples"].size(), 3u);
}

// display "xvfb": the application sees DISPLAY on an X server of the
// capture's own, which is gone afterwards. The program is found on $PATH.
TEST_F(ApplicationCapture, XvfbDisplayAndProgramOnPath) {
  const char* path = std::getenv("PATH");
  if (tally::capture::findOnPath("Xvfb", path ? path : "").empty()) TALLY_SKIP_UNLESS_STRICT("Xvfb is not installed (apt install xvfb)");
  json spec = appSpec("ok", 2, {{"display", "xvfb"}});
  spec["application"]["command"] = {"fake_app.sh"};
  Capture c = capture(spec, {"PATH=" + fs::path(FAKE_APP).parent_path().string() + ":" + (path ? path : "")});
  ASSERT_EQ(c.rc, 0) << c.err;
  EXPECT_NE(c.err.find("[0/3] app:fake_app.sh: starting Xvfb"), std::string::npos) << c.err;
  auto env = record(dir_ / "record.txt");
  ASSERT_EQ(env["DISPLAY"].rfind(":", 0), 0u) << env["DISPLAY"];
  EXPECT_EQ(env["XVFB_SOCKET"], "yes");
  ASSERT_FALSE(env["XVFB_PID"].empty()) << "no Xvfb beside the application";
  EXPECT_EQ(c.result["runs"][0]["notes"]["source"]["display"], "xvfb");
  // Gone: the process and its socket.
  EXPECT_FALSE(fs::exists("/proc/" + env["XVFB_PID"])) << "Xvfb " << env["XVFB_PID"] << " still runs";
  EXPECT_FALSE(fs::exists("/tmp/.X11-unix/X" + env["DISPLAY"].substr(1)));
}

// POST /api/captures: refused unless the daemon allows applications, and
// then to any token but the application token (403); fields named as tallyd
// capture names them; the host's paths inside the application roots only;
// the env from the allowlist.
TEST_F(ApplicationCapture, ServiceChecksApplicationSpecs) {
  fs::path db = dir_ / "tally.db";
  auto opened = tally::store::Store::open(db.string());
  ASSERT_TRUE(opened.ok()) << opened.error();
  tally::service::ServiceContext ctx;
  ctx.writer = opened->get();
  ctx.dbPath = db.string();
  ctx.rendererNames = {"forward"};
  tally::api::Router router;
  tally::service::addServiceRoutes(router, ctx);
  auto post = [&](const json& body, tally::api::Principal principal = tally::api::Principal::kApplication) {
    tally::api::Request req;
    req.method = "POST";
    req.path = "/api/captures";
    req.body = body;
    req.principal = principal;
    return router.dispatch(req);
  };
  auto refused = post(appSpec("ok"));
  EXPECT_EQ(refused.status, 400);
  EXPECT_EQ(refused.json["error"]["field"], "application");
  EXPECT_NE(refused.json["error"]["message"].get<std::string>().find("--allow-applications"), std::string::npos);

  ctx.options.allowApplications = true;
  ctx.options.applicationPolicy.roots = {fs::canonical(fs::path(FAKE_APP).parent_path()),
                                         fs::canonical(dir_)};
  ctx.options.applicationPolicy.env = {"FAKE_APP_*"};
  // The capture token (and the open loopback daemon's kCapture) may not run programs.
  for (auto principal : {tally::api::Principal::kCapture, tally::api::Principal::kRead}) {
    auto forbidden = post(appSpec("ok"), principal);
    EXPECT_EQ(forbidden.status, 403) << forbidden.json.dump();
    EXPECT_EQ(forbidden.json["error"]["code"], "forbidden");
    EXPECT_EQ(forbidden.json["error"]["field"], "Authorization");
  }
  fs::create_directories(dir_ / "inside");
  fs::create_symlink("/etc/shadow", dir_ / "inside" / "shadow.gfxr");
  fs::create_symlink("/bin/sh", dir_ / "inside" / "sh");
  json withEnv = appSpec("ok");
  struct Case {
    json spec;
    std::string field;
  };
  std::vector<Case> cases = {
      {appSpec("ok", 0), "application.frames"},
      {{{"application", {{"command", {"./relative/app"}}}}}, "application.command[0]"},
      {{{"replay", "relative.gfxr"}}, "replay"},
      {{{"replay", (dir_ / "missing.gfxr").string()}}, "replay"},
      {{{"application", {{"command", {FAKE_APP}}}}, {"renderers", {"forward"}}}, "renderers"},
      {{{"application", {{"command", {FAKE_APP}}}}, {"sweep", "depth-reconstruction"}}, "sweep"},
      // Outside the roots: by path, by $PATH lookup, through a link.
      {{{"application", {{"command", {"/bin/sh", "-c", "id > pwned"}}}}}, "application.command[0]"},
      {{{"application", {{"command", {"sh", "-c", "id > pwned"}}}}}, "application.command[0]"},
      {{{"application", {{"command", {(dir_ / "inside" / "sh").string()}}}}}, "application.command[0]"},
      {{{"replay", "/etc/shadow"}}, "replay"},
      {{{"replay", (dir_ / "inside" / "shadow.gfxr").string()}}, "replay"},
      // The loader's injection points, and a name off the allowlist.
      {appSpec("ok", 3, {{"env", {{"LD_PRELOAD", "/tmp/x.so"}}}}), "application.env.LD_PRELOAD"},
      {appSpec("ok", 3, {{"env", {{"PATH", "/tmp"}}}}), "application.env.PATH"},
      {appSpec("ok", 3, {{"env", {{"VK_INSTANCE_LAYERS", "VK_LAYER_x"}}}}),
       "application.env.VK_INSTANCE_LAYERS"},
      {appSpec("ok", 3, {{"env", {{"MY_SETTING", "on"}}}}), "application.env.MY_SETTING"},
  };
  for (const auto& c : cases) {
    auto r = post(c.spec);
    EXPECT_EQ(r.status, 400) << c.spec.dump();
    EXPECT_EQ(r.json["error"]["field"], c.field) << r.json.dump();
  }
  auto accepted = post(appSpec("ok"));
  EXPECT_EQ(accepted.status, 202) << accepted.json.dump();
  // The operator's --application-env lets a name through; LD_* never.
  ctx.options.applicationPolicy.env = {"FAKE_APP_*", "MY_SETTING", "LD_PRELOAD"};
  EXPECT_EQ(post(appSpec("ok", 3, {{"env", {{"MY_SETTING", "on"}}}})).status, 202);
  EXPECT_EQ(post(appSpec("ok", 3, {{"env", {{"LD_PRELOAD", "/tmp/x.so"}}}})).status, 400);
}

// tallyd capture --confine-applications (what the worker runs): the policy
// again, where the program runs. Nothing outside the roots starts; without a
// root no application does; as root, only with --run-as.
TEST_F(ApplicationCapture, ConfinedCaptureRefusesBeforeRunning) {
  auto confined = [&](const json& spec, std::vector<std::string> flags) {
    static int count = 0;
    fs::path specPath = dir_ / ("confined-" + std::to_string(++count) + ".json");
    std::ofstream(specPath) << spec.dump();
    tally::jobs::ChildOptions child;
    child.argv = {TALLYD_PATH,
                  "capture",
                  "--spec",
                  specPath.string(),
                  "--out",
                  (dir_ / "out.json").string(),
                  "--confine-applications"};
    child.argv.insert(child.argv.end(), flags.begin(), flags.end());
    child.environment = {"TALLY_LAYER_PATH=" + layerDir().string()};
    child.deadline = 60s;
    auto ran = tally::jobs::runChild(child);
    EXPECT_TRUE(ran.ok());
    return ran.ok() ? *ran : tally::jobs::ChildResult{};
  };
  const fs::path pwned = dir_ / "pwned";
  const json shell = {{"application", {{"command", {"/bin/sh", "-c", "id > " + pwned.string()}}}}};
  const std::string root = fs::path(FAKE_APP).parent_path().string();
  std::vector<std::string> runAs;
  if (geteuid() == 0) runAs = {"--run-as", "nobody"};

  auto noRoot = confined(shell, runAs);
  EXPECT_EQ(noRoot.exitCode, 1);
  EXPECT_NE(noRoot.stderrTail.find("application: this host runs no applications"), std::string::npos)
      << noRoot.stderrTail;
  std::vector<std::string> flags = {"--application-root", root};
  flags.insert(flags.end(), runAs.begin(), runAs.end());
  auto outside = confined(shell, flags);
  EXPECT_EQ(outside.exitCode, 1);
  EXPECT_NE(outside.stderrTail.find("application.command[0]"), std::string::npos) << outside.stderrTail;
  auto env = confined(appSpec("ok", 3, {{"env", {{"LD_PRELOAD", "/tmp/x.so"}}}}), flags);
  EXPECT_EQ(env.exitCode, 1);
  EXPECT_NE(env.stderrTail.find("application.env.LD_PRELOAD"), std::string::npos) << env.stderrTail;
  EXPECT_FALSE(fs::exists(pwned));
  if (geteuid() == 0) {
    auto asRoot = confined(appSpec("ok"), {"--application-root", root, "--application-env", "FAKE_APP_*"});
    EXPECT_EQ(asRoot.exitCode, 1);
    EXPECT_NE(asRoot.stderrTail.find("refusing to run an application as root"), std::string::npos)
        << asRoot.stderrTail;
    EXPECT_FALSE(fs::exists(dir_ / "record.txt")) << "the application ran as root";
  }
}

// tallyd capture --run-as USER (root only): the application runs as that
// user, with its HOME, and writes the layer's output into a folder made its own.
TEST_F(ApplicationCapture, RunsAsTheRunAsUser) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root (CI runs as root)";
  // The user must reach the record's folder and the capture's temporary folder.
  ::chmod(dir_.c_str(), 0755);
  fs::create_directories(dir_ / "shared");
  ::chmod((dir_ / "shared").c_str(), 01777);
  json spec = appSpec("ok");
  spec["application"]["env"]["FAKE_APP_RECORD"] = (dir_ / "shared" / "record.txt").string();
  fs::path specPath = dir_ / "runas.json", out = dir_ / "runas-result.json";
  std::ofstream(specPath) << spec.dump();
  tally::jobs::ChildOptions child;
  child.argv = {TALLYD_PATH,
                "capture",
                "--spec",
                specPath.string(),
                "--out",
                out.string(),
                "--confine-applications",
                "--application-root",
                fs::path(FAKE_APP).parent_path().string(),
                "--application-env",
                "FAKE_APP_*",
                "--run-as",
                "nobody"};
  child.environment = {"TALLY_LAYER_PATH=" + layerDir().string()};
  child.deadline = 60s;
  child.stderrTailBytes = 1 << 16;
  auto ran = tally::jobs::runChild(child);
  ASSERT_TRUE(ran.ok()) << ran.error();
  ASSERT_TRUE(ran->ok()) << ran->stderrTail;
  const passwd* nobody = getpwnam("nobody");
  ASSERT_NE(nobody, nullptr);
  auto seen = record(dir_ / "shared" / "record.txt");
  EXPECT_EQ(seen["RUN_UID"], std::to_string(nobody->pw_uid)) << "not nobody";
  EXPECT_EQ(seen["USER"], "nobody");
  EXPECT_EQ(seen["HOME"], nobody->pw_dir);
  json result = json::parse(tally::test::readFile(out), nullptr, false);
  ASSERT_TRUE(result.is_object());
  EXPECT_EQ(result["runs"][0]["samples"].size(), 3u);
}

}  // namespace

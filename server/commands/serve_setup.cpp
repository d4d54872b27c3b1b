#include "commands/serve_setup.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <utility>

#include "api/auth.hpp"
#include "api/http_post.hpp"
#include "common/child_process.hpp"
#include "common/log.hpp"
#include "common/paths.hpp"
#include "common/version.hpp"
#include "jobs/worker.hpp"

namespace tally::cli {
namespace {

// The device this worker captures on, probed in a child process (a broken
// driver ends the probe, not the daemon): `tallyd device --json`. Null, with
// a warning, when there is none: the worker then takes only jobs that name
// no device.
nlohmann::json probeDevice(const std::string& self, const std::string& selector) {
  char path[] = "/tmp/tally-device-XXXXXX";
  int fd = mkstemp(path);
  if (fd < 0) return nullptr;
  close(fd);
  jobs::ChildOptions child;
  child.argv = {self, "device", "--json"};
  if (!selector.empty()) child.argv.insert(child.argv.end(), {"--device", selector});
  child.deadline = std::chrono::seconds(60);
  child.stdoutPath = path;
  auto ran = jobs::runChild(child);
  nlohmann::json device;
  if (ran && ran->ok()) {
    std::ifstream in(path);
    device = nlohmann::json::parse(in, nullptr, false);
    if (device.is_discarded() || !device.is_object()) device = nullptr;
  }
  if (device.is_null()) {
    log::warning(std::string("no capture device found (") + (ran ? ran->reason() : ran.error()) +
                 "); this worker takes only jobs that name no device");
  }
  std::filesystem::remove(path);
  return device;
}

Result<ApplicationSetup> applicationSetup(const ServeArgs& args, bool serveHttp, bool runWorker) {
  ApplicationSetup setup;
  setup.captureArgs = {"--confine-applications"};
  if (!args.allowApplications) {
    if (!args.applicationRoots.empty() || !args.applicationEnv.empty() || !args.runAs.empty()) {
      return makeError("--application-root, --application-env and --run-as go with --allow-applications");
    }
    return setup;  // the capture child refuses every application spec: no roots
  }
  if (serveHttp) {
    const std::string how =
        "a token file with an application=<token> line beside read= and capture= (e.g. from "
        "`openssl rand -hex 32`): only its holders may run applications";
    if (args.tokenFile.empty()) return makeError("--allow-applications needs --token-file: " + how);
    auto tokens = api::loadTokenFile(args.tokenFile);
    if (!tokens) return makeError(tokens.error());
    if (tokens->application.empty()) {
      return makeError("--allow-applications: " + args.tokenFile +
                       " has no application=<token> line; it needs " + how);
    }
  }
  if (args.applicationRoots.empty()) {
    return makeError(
        "--allow-applications needs at least one --application-root DIR: the folders an application's "
        "program or a replay file must lie in (links followed), e.g. /opt/tally-apps");
  }
  auto roots = capture::checkApplicationRoots(args.applicationRoots);
  if (!roots) return makeError(roots.error());
  setup.policy.roots = *roots;
  for (const auto& pattern : args.applicationEnv) {
    if (auto checked = capture::checkApplicationEnvPattern(pattern); !checked)
      return makeError(checked.error());
    setup.policy.env.push_back(pattern);
  }
  if (!args.runAs.empty()) {
    if (geteuid() != 0) {
      return makeError("--run-as " + args.runAs +
                       ": tallyd runs as a user of its own already (not root), and applications run as that "
                       "user; drop --run-as");
    }
    auto user = jobs::lookupUser(args.runAs);
    if (!user) return makeError("--run-as: " + user.error());
  } else if (runWorker && geteuid() == 0) {
    return makeError(
        "refusing to run applications as root: give --run-as USER, an unprivileged user they run as "
        "(useradd --system --no-create-home tally-apps), or start tallyd as a user of its own (the "
        "systemd unit's DynamicUser=yes does: docs/operating.md, \"Security model\")");
  }
  for (const auto& root : setup.policy.roots) {
    setup.captureArgs.insert(setup.captureArgs.end(), {"--application-root", root.string()});
  }
  for (const auto& pattern : setup.policy.env) {
    setup.captureArgs.insert(setup.captureArgs.end(), {"--application-env", pattern});
  }
  if (!args.runAs.empty()) setup.captureArgs.insert(setup.captureArgs.end(), {"--run-as", args.runAs});
  return setup;
}

Result<bool> checkAlertWebhook(const ServeArgs& args, bool serveHttp) {
  if (args.alertWebhook.empty()) return true;
  auto target = api::parseHttpUrl(args.alertWebhook);
  if (!target) return makeError("--alert-webhook " + args.alertWebhook + ": " + target.error());
  if (!serveHttp) return makeError("--alert-webhook is for daemons that serve the API (role api or all)");
  return true;
}

// The default database: tally.db in the user's data folder (the unit passes
// --db /var/lib/tally/tally.db).
Result<std::string> defaultDatabase() {
  auto state = userDataDirectory();
  if (!state) return state.failure();
  std::error_code ec;
  std::filesystem::create_directories(*state, ec);
  if (ec) return makeError("cannot create " + state->string() + ": " + ec.message());
  return (*state / "tally.db").string();
}

// The default dashboard: the installed one.
Result<std::string> installedDashboard() {
  std::error_code ec;
  auto data = dataDirectory();
  if (!data || !std::filesystem::is_directory(*data / "web", ec)) {
    return makeError(std::string("no dashboard to serve (") +
                     (data ? (*data / "web").string() + " is not a folder" : data.error()) + "); give --web");
  }
  return (*data / "web").string();
}

std::string thisHostName() {
  char name[256] = {};
  gethostname(name, sizeof name - 1);
  return name;
}

}  // namespace

Result<ServeSetup> resolveServeSetup(const ServeArgs& args, std::string self) {
  ServeSetup setup;
  setup.self = std::move(self);
  setup.serveHttp = args.role != "worker";
  setup.runWorker = args.role != "api";
  auto applications = applicationSetup(args, setup.serveHttp, setup.runWorker);
  if (!applications) return applications.failure();
  setup.applications = std::move(*applications);
  if (auto webhook = checkAlertWebhook(args, setup.serveHttp); !webhook) return webhook.failure();
  setup.postgres = store::isPostgresUrl(args.db);
  setup.dbPath = args.db;
  if (setup.dbPath.empty()) {
    auto db = defaultDatabase();
    if (!db) return db.failure();
    setup.dbPath = *db;
  }
  setup.dbName = setup.postgres ? store::redactUrl(setup.dbPath) : setup.dbPath;
  setup.webRoot = args.web;
  if (setup.webRoot.empty() && setup.serveHttp) {
    auto web = installedDashboard();
    if (!web) return web.failure();
    setup.webRoot = *web;
  }
  setup.hostName = args.hostName.empty() ? thisHostName() : args.hostName;
  setup.selector = args.device.empty() ? "auto" : args.device;
  setup.lease = std::chrono::milliseconds(int64_t(args.leaseSeconds * 1000));
  setup.staleAfter = std::chrono::milliseconds(int64_t(args.staleSeconds * 1000));
  return setup;
}

store::HostInfo workerHost(const ServeArgs& args, const ServeSetup& setup) {
  store::HostInfo host;
  host.name = setup.hostName;
  host.instance = jobs::Worker::newInstance();
  host.role = args.role;
  host.tallyVersion = std::string(version());
  host.tallyCommit = std::string(gitCommit());
  host.device = probeDevice(setup.self, args.device);
  if (!args.deviceNameOverride.empty()) {
    host.deviceOverride = args.deviceNameOverride;
    if (host.device.is_object()) {
      host.device["name_reported"] = host.device.value("name", "");
      host.device["name"] = args.deviceNameOverride;
    }
  }
  return host;
}

}  // namespace tally::cli

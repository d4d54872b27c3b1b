// Store faults through a real `tallyd serve` (docs/operating.md, "Store
// faults"): a database file damaged in the middle, a full disk (a small
// tmpfs; mounting needs root, as CI runs), and a PostgreSQL server that went
// away. Each is named: /api/health answers 503 with the store's state,
// /metrics shows it, and routes that meet it answer 503 with Retry-After and
// the reason, never 500. A job that fails while the disk is full is failed
// with its reason once the store takes writes again.
//
// Also the scene listing: only files inside the --scenes folders.
#include <fcntl.h>
#include <sys/mount.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include "strict.hpp"

#include "daemon.hpp"
#include "postgres_server.hpp"
#include "store/store.hpp"
#include "store_fixture.hpp"

namespace {

using namespace tally::service::test;
namespace store = tally::store;

// A reply with its headers, which Daemon::request leaves out.
struct Answer {
  int status = 0;
  std::string body, retryAfter;
  json j() const { return json::parse(body, nullptr, false); }
};

// The bearer token requests carry, where the daemon has a token file.
std::string gToken;

Answer ask(const Daemon& d, const std::string& method, const std::string& path,
           const std::string& body = {}) {
  httplib::Client client("127.0.0.1", d.port());
  client.set_read_timeout(15, 0);
  if (!gToken.empty()) client.set_bearer_token_auth(gToken);
  httplib::Result res = method == "GET"    ? client.Get(path.c_str())
                        : method == "POST" ? client.Post(path.c_str(), body, "application/json")
                                           : client.Delete(path.c_str());
  Answer a;
  if (!res) return a;
  a.status = res->status;
  a.body = res->body;
  a.retryAfter = res->get_header_value("Retry-After");
  return a;
}

// Polls `done` (bounded) every 100 ms; true once it holds.
template <class F>
bool eventually(F done, std::chrono::seconds limit) {
  auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(100ms);
  }
  return done();
}

// A 503 naming the store: code store_unavailable, Retry-After, a reason.
void expectStoreUnavailable(const Answer& a, const std::string& what, const std::string& reasonHas) {
  EXPECT_EQ(a.status, 503) << what << ": " << a.body;
  EXPECT_FALSE(a.retryAfter.empty()) << what;
  EXPECT_EQ(a.j()["error"]["code"], "store_unavailable") << what << ": " << a.body;
  EXPECT_NE(a.j()["error"]["message"].get<std::string>().find(reasonHas), std::string::npos)
      << what << ": " << a.body;
}

// ---- a file damaged in the middle ---------------------------------------------------

TEST(StoreFaults, AFileDamagedInTheMiddleIsNamed) {
  fs::path dir = makeTempDir("tally-store-damaged");
  fs::path db = dir / "tally.db";
  {
    auto opened = store::Store::open(db.string());
    ASSERT_TRUE(opened) << opened.error();
    auto& s = **opened;
    for (int i = 0; i < 40; ++i) {
      auto job = s.jobs().create({{"renderers", {"forward"}}});
      ASSERT_TRUE(job) << job.error();
      auto claimed = s.jobs().claim();
      ASSERT_TRUE(claimed && claimed->has_value());
      auto capture = store::testing::realisticCapture(i);
      auto stored = s.runs().ingestCapture(job->job.id, capture.result, capture.screenshots);
      ASSERT_TRUE(stored) << stored.error();
      ASSERT_TRUE(s.jobs().finish(job->job.id, store::JobStatus::Done));
    }
  }  // closed: the WAL is checkpointed into the file and removed
  ASSERT_FALSE(fs::exists(fs::path(db.string() + "-wal")));
  const auto size = fs::file_size(db);
  constexpr size_t kPage = 4096, kPages = 20;
  ASSERT_GT(size, 4 * kPages * kPage) << "too small a file to damage in the middle";
  {
    // 20 pages of noise from the middle on, page-aligned.
    int fd = ::open(db.c_str(), O_WRONLY);
    ASSERT_GE(fd, 0);
    std::mt19937 random(31);
    std::vector<char> noise(kPages * kPage);
    for (char& c : noise) c = char(random());
    off_t at = off_t(size / 2 / kPage * kPage);
    ASSERT_EQ(::pwrite(fd, noise.data(), noise.size(), at), ssize_t(noise.size()));
    ::close(fd);
  }

  // It starts (page 1 is whole), and says what is wrong.
  Daemon d(dir, db);
  ASSERT_TRUE(d.start()) << "tallyd serve did not start on a damaged file";
  Answer health = ask(d, "GET", "/api/health");
  EXPECT_EQ(health.status, 503) << health.body;
  EXPECT_FALSE(health.retryAfter.empty());
  EXPECT_EQ(health.j()["status"], "unavailable") << health.body;
  EXPECT_EQ(health.j()["store"]["status"], "damaged") << health.body;
  EXPECT_NE(health.j()["store"]["reason"].get<std::string>().find("quick_check"), std::string::npos)
      << health.body;
  EXPECT_NE(health.j()["store"]["check"].get<std::string>(), "ok");

  Answer metrics = ask(d, "GET", "/metrics");
  EXPECT_EQ(metrics.status, 200);
  EXPECT_NE(metrics.body.find("\ntally_store_up 0\n"), std::string::npos) << metrics.body;
  EXPECT_NE(metrics.body.find("\ntally_store_fault{fault=\"damaged\"} 1\n"), std::string::npos)
      << metrics.body;

  // Reads that meet the damage answer 503 naming it, never 500; the others answer.
  int refused = 0;
  for (const char* path : {"/api/runs?limit=1000", "/api/export?format=json", "/api/captures?limit=1000",
                           "/api/devices", "/api/sweeps"}) {
    Answer a = ask(d, "GET", path);
    EXPECT_TRUE(a.status == 200 || a.status == 503) << path << ": " << a.status << " " << a.body;
    if (a.status == 503) {
      expectStoreUnavailable(a, path, "damaged");
      ++refused;
    }
  }
  EXPECT_GT(refused, 0) << "no route met the damage";
  Answer runs = ask(d, "GET", "/api/runs?limit=1000");
  expectStoreUnavailable(runs, "GET /api/runs", "damaged");
  // Writes are refused while the store is damaged.
  expectStoreUnavailable(ask(d, "POST", "/api/captures", tinySpec().dump()), "POST /api/captures", "damaged");
  EXPECT_EQ(d.stop(SIGTERM), 0);
  fs::remove_all(dir);
}

// ---- a full disk ------------------------------------------------------------------------

// A tmpfs of `size` at `dir`, unmounted (lazily, so a process still holding
// a file cannot keep it) when the test ends, passed or not.
class Tmpfs {
 public:
  Tmpfs(const fs::path& dir, const std::string& size) : dir_(dir) {
    fs::create_directories(dir);
    mounted_ = ::mount("tmpfs", dir.c_str(), "tmpfs", 0, ("size=" + size).c_str()) == 0;
    if (!mounted_) error_ = std::strerror(errno);
  }
  ~Tmpfs() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }

 private:
  fs::path dir_;
  bool mounted_ = false;
  std::string error_;
};

// Writes zeros to `file` until the file system has no room left.
void fill(const fs::path& file) {
  int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(fd, 0);
  std::vector<char> zeros(16384, 0);
  while (::write(fd, zeros.data(), zeros.size()) > 0) {
  }
  for (size_t small = 4096; small > 0; small /= 2) {
    while (::write(fd, zeros.data(), small) > 0) {
    }
  }
  ::close(fd);
}

class FullDisk : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = makeTempDir("tally-store-full");
    fs::create_directories(dir_ / "layer");
    std::ofstream(dir_ / "layer" / "VkLayer_tally_counters.json") << "{}";
    setenv("TALLY_LAYER_PATH", (dir_ / "layer").string().c_str(), 1);
  }
  void TearDown() override {
    gToken.clear();
    unsetenv("TALLY_LAYER_PATH");
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

TEST_F(FullDisk, WritesAnswer503AndTheRunningJobIsFailedOnceThereIsRoom) {
  Tmpfs disk(dir_ / "disk", "4m");
  // Root may mount (CI and a root scripts/test.sh): there a refusal is a failure.
  if (!disk.mounted() && geteuid() == 0) TALLY_SKIP_UNLESS_STRICT("cannot mount a tmpfs as root (" << disk.error() << ")");
  if (!disk.mounted()) GTEST_SKIP() << "cannot mount a tmpfs (" << disk.error() << "); run as root";
  {
    // The daemon stops before the tmpfs goes (declared after it).
    // Applications as the security model allows them (docs/operating.md): the
    // application token, tests/capture as the root, nobody's user under root.
    ApplicationTokens tokens = writeApplicationTokens(dir_);
    std::vector<std::string> flags = applicationFlags(tokens, {fs::path(FAKE_APP).parent_path()}, {"FAKE_APP_*"});
    flags.insert(flags.end(), {"--job-deadline", "6"});
    gToken = tokens.application;
    Daemon d(dir_, dir_ / "disk" / "tally.db", flags);
    d.setToken(tokens.application);
    ASSERT_TRUE(d.start()) << "tallyd serve did not start";
    EXPECT_EQ(ask(d, "GET", "/api/health").status, 200);

    // A job that runs until its deadline.
    json app = {{"command", {FAKE_APP}}, {"frames", 3}, {"env", {{"FAKE_APP_MODE", "hang"}}}};
    Answer posted = ask(d, "POST", "/api/captures", json{{"application", app}}.dump());
    ASSERT_EQ(posted.status, 202) << posted.body;
    const int64_t id = posted.j()["id"].get<int64_t>();
    ASSERT_TRUE(eventually(
        [&] { return d.request("GET", "/api/captures/" + std::to_string(id)).j()["status"] == "running"; },
        30s));

    fill(dir_ / "disk" / "filler");
    // New captures: 503 with Retry-After naming the full disk, never 500.
    Answer refused;
    for (int i = 0; i < 10 && refused.status != 503; ++i) {
      refused = ask(d, "POST", "/api/captures", json{{"application", app}}.dump());
      EXPECT_NE(refused.status, 500) << refused.body;
      if (refused.status == 202) std::this_thread::sleep_for(100ms);  // the WAL had room left
    }
    expectStoreUnavailable(refused, "POST /api/captures", "full");
    Answer health = ask(d, "GET", "/api/health");
    EXPECT_EQ(health.status, 503) << health.body;
    EXPECT_EQ(health.j()["store"]["status"], "full") << health.body;
    EXPECT_NE(ask(d, "GET", "/metrics").body.find("tally_store_fault{fault=\"full\"} 1"), std::string::npos);
    // Cancelling the running job is a write too: 503, not 500.
    Answer cancel = ask(d, "DELETE", "/api/captures/" + std::to_string(id));
    EXPECT_NE(cancel.status, 500) << cancel.body;
    if (cancel.status != 200) expectStoreUnavailable(cancel, "DELETE /api/captures/{id}", "full");

    // The job reaches its deadline (and the grace after it) while nothing
    // can be written: it stays running in the store, its failure waiting in
    // the worker.
    EXPECT_TRUE(d.waitNoJobChildren(30s)) << "the capture child outlived its deadline";
    std::this_thread::sleep_for(1s);
    json job = d.request("GET", "/api/captures/" + std::to_string(id)).j();
    if (cancel.status != 200) {
      EXPECT_EQ(job["status"], "running") << job.dump();
    }

    // Room again: the failure is recorded with its reason, health returns.
    fs::remove(dir_ / "disk" / "filler");
    ASSERT_TRUE(eventually(
        [&] { return d.request("GET", "/api/captures/" + std::to_string(id)).j()["status"] != "running"; },
        30s));
    job = d.request("GET", "/api/captures/" + std::to_string(id)).j();
    if (cancel.status != 200) {
      EXPECT_EQ(job["status"], "failed") << job.dump();
      EXPECT_FALSE(job["error"].is_null()) << job.dump();
    }
    EXPECT_TRUE(eventually([&] { return ask(d, "GET", "/api/health").status == 200; }, 30s));
    EXPECT_EQ(ask(d, "GET", "/api/health").j()["store"]["status"], "ok");
    Answer again = ask(d, "POST", "/api/captures",
                       json{{"application", {{"command", {FAKE_APP}}, {"frames", 3}}}}.dump());
    EXPECT_EQ(again.status, 202) << again.body;
    if (again.status == 202) d.waitFinished(again.j()["id"].get<int64_t>(), 60s);
    EXPECT_EQ(d.stop(SIGTERM), 0);
  }
}

// ---- PostgreSQL gone ----------------------------------------------------------------------

TEST(StoreFaults, APostgresServerThatWentAwayIsNamed) {
  tally::testing::PostgresServer server;
  if (auto why = server.start()) {
    TALLY_SKIP_UNLESS_STRICT(*why);
  }
  fs::path dir = makeTempDir("tally-store-pg-gone");
  {
    std::string url = server.createDatabase();
    Daemon d(dir, url, {"--role", "api"});
    ASSERT_TRUE(d.start());
    Answer health = ask(d, "GET", "/api/health");
    EXPECT_EQ(health.status, 200) << health.body;
    EXPECT_EQ(health.j()["store"]["engine"], "postgresql");
    EXPECT_EQ(ask(d, "GET", "/api/runs").status, 200);

    server.stop();
    expectStoreUnavailable(ask(d, "GET", "/api/runs"), "GET /api/runs", "cannot be reached");
    expectStoreUnavailable(ask(d, "POST", "/api/captures", tinySpec().dump()), "POST /api/captures",
                           "cannot be reached");
    health = ask(d, "GET", "/api/health");
    EXPECT_EQ(health.status, 503) << health.body;
    EXPECT_EQ(health.j()["store"]["status"], "unreachable") << health.body;
    EXPECT_EQ(d.stop(SIGTERM), 0);
  }
  fs::remove_all(dir);
}

// ---- the scene listing ----------------------------------------------------------------------

TEST(SceneListing, OnlyFilesInsideTheFoldersAreListed) {
  fs::path dir = makeTempDir("tally-scene-listing");
  fs::create_directories(dir / "scenes" / "sub");
  fs::create_directories(dir / "elsewhere");
  std::ofstream(dir / "scenes" / "a.gltf") << "{}";
  std::ofstream(dir / "scenes" / "sub" / "b.glb") << "glTF";
  std::ofstream(dir / "elsewhere" / "secret.gltf") << "{}";
  fs::create_symlink(dir / "scenes" / "a.gltf", dir / "scenes" / "same.gltf");         // inside: listed
  fs::create_symlink("/etc/hostname", dir / "scenes" / "escape.gltf");                 // out: not listed
  fs::create_symlink(dir / "elsewhere" / "secret.gltf", dir / "scenes" / "out.gltf");  // out: not listed
  fs::create_symlink(dir / "elsewhere", dir / "scenes" / "linked");                    // a folder out
  {
    Daemon d(dir, dir / "tally.db", {"--scenes", (dir / "scenes").string(), "--role", "api"});
    ASSERT_TRUE(d.start());
    Reply scenes = d.request("GET", "/api/scenes");
    ASSERT_EQ(scenes.status, 200) << scenes.body;
    std::vector<std::string> files;
    const json listing = scenes.j();
    for (const auto& f : listing["gltf"][0]["files"]) files.push_back(f.get<std::string>());
    std::sort(files.begin(), files.end());
    EXPECT_EQ(files, (std::vector<std::string>{"a.gltf", "same.gltf", "sub/b.glb"})) << scenes.body;
    EXPECT_EQ(scenes.body.find("secret"), std::string::npos);
    EXPECT_EQ(scenes.body.find("hostname"), std::string::npos);
    EXPECT_EQ(d.stop(SIGTERM), 0);
  }
  fs::remove_all(dir);
}

}  // namespace

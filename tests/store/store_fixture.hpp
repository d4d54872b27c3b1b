// Shared by the store tests: temporary databases and capture results built as
// docs/result-schema.md describes them.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "postgres_server.hpp"
#include "store/migrations.hpp"
#include "store/sqlite.hpp"
#include "store/store.hpp"

namespace tally::store::testing {

using nlohmann::json;

// The engine the store tests run on: SQLite files, or with
// TALLY_TEST_STORE=postgres a fresh PostgreSQL database per test, on the
// server in TALLY_TEST_POSTGRES (its maintenance database's URL,
// postgresql://tally@127.0.0.1:PORT/postgres) or else one this process
// starts (tests/support/postgres_server.hpp). ctest runs the engine-neutral
// suites both ways: store.* on SQLite, store.postgresql on PostgreSQL.
inline const char* postgresServer() {
  const char* engine = std::getenv("TALLY_TEST_STORE");
  if (!engine || std::string(engine) != "postgres") return nullptr;
  const char* url = std::getenv("TALLY_TEST_POSTGRES");
  if (url && *url) return url;
  static std::string own;
  if (own.empty()) {
    auto* server = tally::testing::requirePostgres();
    if (!server) throw std::runtime_error("TALLY_TEST_STORE=postgres, and no PostgreSQL server could be started");
    own = server->url("postgres");
  }
  return own.c_str();
}

// A database for one test: a file in the temporary directory, removed (with
// -wal, -shm) afterwards, or a PostgreSQL database, dropped afterwards.
class TempDb {
 public:
  TempDb() {
    static std::atomic<int> counter{0};
    std::string name = "tally_store_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++);
    if (const char* server = postgresServer()) {
      server_ = server;
      name_ = name;
      auto admin = openPostgres(server_);
      admin->exec("DROP DATABASE IF EXISTS " + name_);
      admin->exec("CREATE DATABASE " + name_);
      std::string base = server_.substr(0, server_.rfind('/'));
      path_ = base + "/" + name_;
      return;
    }
    path_ = (std::filesystem::temp_directory_path() / (name + ".db")).string();
    removeFiles();
  }
  ~TempDb() {
    if (!server_.empty()) {
      try {
        openPostgres(server_)->exec("DROP DATABASE IF EXISTS " + name_ + " WITH (FORCE)");
      } catch (const std::exception& e) {
        ADD_FAILURE() << e.what();
      }
      return;
    }
    removeFiles();
  }
  const std::string& path() const { return path_; }
  bool postgres() const { return !server_.empty(); }

 private:
  void removeFiles() {
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) std::filesystem::remove(path_ + suffix);
  }
  std::string path_, server_, name_;
};

inline std::unique_ptr<Store> openStore(const std::string& path, Store::Options options = {}) {
  auto store = Store::open(path, options);
  if (!store) ADD_FAILURE() << store.error();
  return store ? std::move(store).value() : nullptr;
}

// Runs a one-value query on the store's connection (test-only SQL, no values).
inline int64_t scalar(Store& store, const std::string& sql) {
  try {
    Statement statement(store.connection(), sql);
    return statement.step() ? statement.getInt(0) : -1;
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();
    return -1;
  }
}

// The SQLite handle of a store on a file (SQLite-only tests).
inline sqlite3* handle(Store& store) { return static_cast<SqliteConnection&>(store.connection()).raw(); }

// The migration functions on a raw SQLite handle (not closed afterwards).
inline Result<int> migrate(sqlite3* raw, std::span<const Migration> migrations) {
  SqliteConnection connection(raw, "test", /*owns=*/false);
  return store::migrate(connection, migrations);
}
inline Result<int> schemaVersion(sqlite3* raw) {
  SqliteConnection connection(raw, "test", /*owns=*/false);
  return store::schemaVersion(connection);
}

// A minimal PNG: signature, IHDR (width, height), IEND. Enough for the store.
inline std::vector<uint8_t> fakePng(uint32_t width, uint32_t height, uint8_t tag = 0) {
  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
  for (uint32_t v : {width, height}) {
    for (int shift = 24; shift >= 0; shift -= 8) png.push_back(static_cast<uint8_t>(v >> shift));
  }
  png.insert(png.end(),
             {8, 6, 0, 0, 0, tag, tag, tag, tag, 0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82});
  return png;
}

inline json device(const std::string& name = "llvmpipe (LLVM 15.0.6, 256 bits)") {
  return {{"index", 0},
          {"name", name},
          {"type", "cpu"},
          {"vendorID", "0x10005"},
          {"deviceID", "0x0000"},
          {"apiVersion", "1.3.230"},
          {"driverInfo", "Mesa 22.3.6"},
          {"subgroupSize", 8},
          {"features", {{"int64Atomics", true}, {"fragmentBarycentric", false}}}};
}

inline json spread(double median) {
  return {{"median", median},    {"q1", median * 0.98}, {"q3", median * 1.02}, {"iqr", median * 0.04},
          {"min", median * 0.9}, {"max", median * 1.1}, {"mean", median},      {"n", 20}};
}

inline json makeCounter(const std::string& name, const std::string& access, double count, double bytes,
                        const std::string& source = "counter") {
  return {{"name", name},
          {"format", "R8G8B8A8_UNORM"},
          {"kind", "texture"},
          {"access", access},
          {"count", count},
          {"bytes", bytes},
          {"count_spread", spread(count)},
          {"source", source}};
}

inline json makePass(const std::string& name, double gpuMs, double fragments, std::vector<json> counters) {
  return {{"name", name},
          {"gpu_ms", gpuMs},
          {"gpu_ms_spread", spread(gpuMs)},
          {"gpu_ms_instrumented", gpuMs * 1.1},
          {"overhead_ratio", 1.1},
          {"fragment_invocations", fragments},
          {"fragment_invocations_statistic", fragments + 8},
          {"resources", std::move(counters)}};
}

inline json makeSample(int index, double frameMs, std::vector<json> passes,
                       const std::string& screenshot = "") {
  json s = {
      {"camera",
       {{"eye", {1.0, 2.0, 3.0}},
        {"target", {0.0, 0.0, 0.0}},
        {"fov_deg", 60},
        {"label", "cam"},
        {"index", index}}},
      {"sky_fraction", 0.25 * index},
      {"sky_fraction_estimate", 0.25 * index + 0.01},
      {"image_error",
       {{"against", "forward"}, {"psnr", 41.5}, {"identical", false}, {"max_abs", 12}, {"mean_abs", 0.4}}},
      {"frames", 20},
      {"frame_ms", frameMs},
      {"frame_ms_spread", spread(frameMs)},
      {"frame_ms_instrumented", frameMs * 1.1},
      {"overhead_ratio", 1.1},
      {"passes", std::move(passes)}};
  s["screenshot"] = screenshot.empty() ? json(nullptr) : json(screenshot);
  return s;
}

inline json makeRun(const std::string& renderer, const std::string& scene, int width, int height,
                    std::vector<json> samples) {
  return {{"renderer", renderer},
          {"scene", scene},
          {"scene_params", {{"seed", 1}}},
          {"width", width},
          {"height", height},
          {"counting", "exact"},
          {"lights", 400},
          {"notes", {{"barycentrics", "extension"}}},
          {"resources",
           {{"render_target_bytes", int64_t{width} * height * 12},
            {"list",
             {{{"name", "gbuffer.normal"},
               {"kind", "attachment"},
               {"format", "R16G16B16A16_SFLOAT"},
               {"element_bytes", 8},
               {"width", width},
               {"height", height},
               {"allocation_bytes", int64_t{width} * height * 8 + 2048},
               {"format_bytes", int64_t{width} * height * 8},
               {"usage", "color_attachment|sampled"}},
              {{"name", "depth"},
               {"kind", "depth"},
               {"format", "D32_SFLOAT_S8_UINT"},
               {"element_bytes", 5},
               {"width", width},
               {"height", height},
               {"allocation_bytes", int64_t{width} * height * 8},
               {"format_bytes", int64_t{width} * height * 5},
               {"usage", "depth_stencil_attachment"}}}}}},
          {"samples", std::move(samples)}};
}

// A sweep result of the documented shape (docs/result-schema.md, "Sweep
// results"): two near values x two distances, error growing with distance.
inline json sweepResult(const std::string& name = "depth-reconstruction",
                 const std::string& deviceName = "llvmpipe (LLVM 15.0.6, 256 bits)") {
  json points = json::array();
  for (double near : {0.01, 1.0}) {
    for (double distance : {3.0, 300.0}) {
      double relative = 1e-7 * distance / near;
      points.push_back({{"near", near},
                        {"far", 1000.0},
                        {"far_over_near", 1000.0 / near},
                        {"distance", distance},
                        {"error", {{"max_abs", relative * distance}, {"max_relative", relative}}}});
    }
  }
  return {{"sweep", name},
          {"device", device(deviceName)},
          {"spec", {{"sweep", name}, {"near", {0.01, 1.0}}, {"far", {1000.0}}, {"distances", {3.0, 300.0}}}},
          {"parameters", {"near", "far", "distance"}},
          {"threshold", {{"relative", 1e-4}}},
          {"points", points},
          // 1e-7 * 300 / 0.01 = 3e-3 fails; 1e-7 * 3 / 0.01 = 3e-5 and 3e-5 (near 1, 300 m) do not.
          {"fails_at",
           {{"distance",
             {{{"near", 0.01}, {"far", 1000.0}, {"distance", 300.0}},
              {{"near", 1.0}, {"far", 1000.0}, {"distance", nullptr}}}}}},
          {"plots",
           {{{"title", "Error against distance"},
             {"x", "distance"},
             {"x_log", true},
             {"y", "error.max_relative"},
             {"y_log", true},
             {"y_label", "max relative error"},
             {"series", {"near", "far"}},
             {"threshold", 1e-4}}}}};
}

inline json makeCapture(std::vector<json> runs,
                        const std::string& deviceName = "llvmpipe (LLVM 15.0.6, 256 bits)") {
  return {{"device", device(deviceName)},
          {"spec", {{"renderers", {"forward", "deferred"}}, {"resolutions", {{320, 180}}}}},
          {"shaders", {{"forward.frag.glsl", "9c1d00aa"}, {"deferred.frag.glsl", "77aa0011"}}},
          {"runs", std::move(runs)}};
}

struct Capture {
  json result;
  std::map<std::string, std::vector<uint8_t>> screenshots;
};

// 2 runs (forward, deferred) x 2 samples x 4 passes x 3 counters each, with
// screenshots; `seed` shifts every value so captures differ.
inline Capture realisticCapture(int seed = 0, const std::string& scene = "atrium", int width = 320,
                                int height = 180,
                                const std::string& deviceName = "llvmpipe (LLVM 15.0.6, 256 bits)") {
  Capture c;
  std::vector<json> runs;
  const std::vector<std::pair<std::string, std::vector<std::string>>> renderers = {
      {"forward", {"depth", "opaque", "skybox", "post"}},
      {"deferred", {"gbuffer", "lighting", "skybox", "post"}}};
  for (size_t r = 0; r < renderers.size(); ++r) {
    std::vector<json> samples;
    for (int s = 0; s < 2; ++s) {
      std::vector<json> passes;
      double frame = 0;
      for (size_t p = 0; p < 4; ++p) {
        double base = seed * 1000 + r * 100 + s * 10 + p;
        double gpu = 0.25 + 0.125 * static_cast<double>(p) + 0.0625 * s + 0.5 * static_cast<double>(r);
        frame += gpu;
        passes.push_back(makePass(renderers[r].second[p], gpu, 57600 + base,
                                  {makeCounter("material_maps.diffuse", "read", base * 4, base * 16),
                                   makeCounter("gbuffer.normal", "write", base * 2, base * 16),
                                   makeCounter("depth", "write", base, base * 5, "derived")}));
      }
      std::string shot = renderers[r].first + "_" + scene + "_" + std::to_string(width) + "x" +
                         std::to_string(height) + "_cam" + std::to_string(s) + ".png";
      samples.push_back(makeSample(s, frame, std::move(passes), shot));
      c.screenshots[shot] = fakePng(width, height, static_cast<uint8_t>(seed + r * 2 + s));
    }
    runs.push_back(makeRun(renderers[r].first, scene, width, height, std::move(samples)));
  }
  // The forward run is the reference: identical images, no sky on camera 0.
  runs[0]["samples"][0]["image_error"] = {
      {"against", "forward"}, {"psnr", nullptr}, {"identical", true}, {"max_abs", 0}, {"mean_abs", 0}};
  runs[0]["samples"][0]["sky_fraction"] = -1.0;
  c.result = makeCapture(std::move(runs), deviceName);
  return c;
}

// A capture with every kind of missing value: identical images (NULL psnr),
// a sample without image error, without instrumented time or overhead, with
// and without footprint, with and without per-frame times, and a run without
// samples; times whose sums depend on the order they are added in.
inline Capture mixedCapture(double shift) {
  Capture c = realisticCapture(static_cast<int>(shift));
  json& runs = c.result["runs"];
  // forward: every sample with its per-frame times (18 frames: an interval).
  for (size_t s = 0; s < runs[0]["samples"].size(); ++s) {
    json frames = json::array();
    for (int f = 0; f < 9; ++f) frames.push_back(0.1 * (f + 1) + 0.3 * static_cast<double>(s) + shift);
    runs[0]["samples"][s]["frame_ms_frames"] = frames;
    runs[0]["samples"][s]["frame_ms"] = 0.1 + 0.2 * static_cast<double>(s) + shift;
  }
  // deferred: one sample with per-frame times, one without (the samples' medians);
  // the second has no image error, no instrumented time and no overhead, the
  // first a footprint on one of its counters.
  runs[1]["samples"][0]["frame_ms_frames"] = {0.7, 0.1, 0.2};
  runs[1]["samples"][1].erase("image_error");
  runs[1]["samples"][1].erase("frame_ms_instrumented");
  runs[1]["samples"][1].erase("overhead_ratio");
  runs[1]["samples"][0]["passes"][0]["resources"][0]["footprint_bytes"] = 0.3 + shift;
  runs[1]["samples"][0]["passes"][1]["resources"][1]["footprint_bytes"] = 0.1;
  // Three samples of 0.1, 0.2, 0.3 ms: (0.1 + 0.2) + 0.3 != 0.1 + (0.2 + 0.3).
  json third = runs[1]["samples"][1];
  third["camera"]["index"] = 2;
  third["screenshot"] = nullptr;
  third["frame_ms_frames"] = json::array();  // stored as none
  runs[1]["samples"].push_back(third);
  for (size_t s = 0; s < 3; ++s) runs[1]["samples"][s]["frame_ms"] = 0.1 * static_cast<double>(s + 1);
  // A run without samples.
  json empty = runs[1];
  empty["renderer"] = "visbuffer";
  empty["samples"] = json::array();
  runs.push_back(empty);
  return c;
}

// A store on a fresh temporary file; checks integrity after every test.
class StoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = openStore(db_.path());
    ASSERT_NE(store_, nullptr);
  }
  void TearDown() override {
    if (!store_) return;
    auto integrity = store_->integrityCheck();
    ASSERT_TRUE(integrity) << integrity.error();
    EXPECT_EQ(*integrity, "ok");  // with no foreign key violations
    store_.reset();  // closed before the database is dropped
  }
  int64_t newJob(const std::string& key = "") {
    auto job =
        store_->jobs().create({{"renderers", {"forward"}}}, key.empty() ? std::nullopt : std::optional(key));
    EXPECT_TRUE(job) << job.error();
    return job ? job->job.id : 0;
  }
  int64_t ingest(int64_t jobId, const Capture& c) {
    auto stored = store_->runs().ingestCapture(jobId, c.result, c.screenshots);
    EXPECT_TRUE(stored) << stored.error();
    return stored ? *stored : -1;
  }

  TempDb db_;
  std::unique_ptr<Store> store_;
};

}  // namespace tally::store::testing

// The client library against the fake tallyd: requests, the wire mapping,
// error messages, and the table formats.
#include <gtest/gtest.h>

#include "api_client.hpp"
#include "fake_tallyd.hpp"
#include "tables.hpp"

namespace tally::client {
namespace {

using test::FakeTallyd;

TEST(ApiClient, SubmitsSpecWithKeyAndToken) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url(), .token = "s3cret"});
  auto res = api.submitCapture({{"renderers", {"forward"}}}, "key-1");
  ASSERT_TRUE(res) << res.error();
  EXPECT_EQ(jobView(*res).id, "7");
  EXPECT_EQ(jobView(*res).status, "queued");
  EXPECT_EQ(fake.lastIdempotencyKey(), "key-1");
  EXPECT_EQ(fake.lastAuthorization(), "Bearer s3cret");
  EXPECT_EQ(json::parse(fake.lastSpec()), json({{"renderers", {"forward"}}}));
}

TEST(ApiClient, JobGoesQueuedRunningDone) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url()});
  std::vector<std::string> states;
  for (int i = 0; i < 4; ++i) {
    auto res = api.getCapture("7");
    ASSERT_TRUE(res) << res.error();
    states.push_back(jobView(*res).status);
  }
  EXPECT_EQ(states, (std::vector<std::string>{"queued", "running", "running", "done"}));
  JobView done = jobView(*api.getCapture("7"));
  EXPECT_TRUE(done.finished());
  EXPECT_EQ(done.done, 40);
  EXPECT_EQ(done.total, 40);
  EXPECT_DOUBLE_EQ(*done.fraction, 1.0);
  EXPECT_EQ(done.current, "deferred atrium 320x180 camera 3");
  EXPECT_EQ(done.runs, (std::vector<std::string>{"12", "15"}));
}

TEST(ApiClient, ServerErrorsAreFormatted) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url()});
  auto res = api.submitCapture({{"renderers", {"forward"}}, {"resolutions", {{0, 180}}}});
  ASSERT_FALSE(res);
  EXPECT_EQ(
      res.error(),
      "error (400 invalid_field, field resolutions[0][0]): must be an integer between 1 and 16384, got 0");
  auto missing = api.getRun("404");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error(), "error (404 not_found): run 404 not found");
}

TEST(ApiClient, NonJsonErrorBody) {
  EXPECT_EQ(formatHttpError(502, "<html>bad gateway</html>\nmore"), "error (502): <html>bad gateway</html>");
  EXPECT_EQ(formatHttpError(500, ""), "error (500): HTTP 500");
}

TEST(ApiClient, RefusedConnectionNamesTheServer) {
  std::string url = "http://127.0.0.1:" + std::to_string(test::deadPort());
  ApiClient api({.server = url});
  auto res = api.listRuns({}, std::nullopt);
  ASSERT_FALSE(res);
  EXPECT_EQ(res.error(),
            "cannot reach tallyd at " + url + ": connection refused (is `tallyd serve` running?)");
}

TEST(ApiClient, RunFiltersAndCursors) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url()});
  RunFilters f;
  f.renderer = "deferred";
  f.scene = "atrium";
  f.width = 320;
  f.device = "llvmpipe (LLVM)";
  auto page = api.listRuns(f, 2);
  ASSERT_TRUE(page) << page.error();
  EXPECT_EQ(runList(*page).size(), 2u);
  EXPECT_EQ(nextCursor(*page), "r9");
  auto q = fake.lastRunsQuery();
  EXPECT_EQ(q.find("renderer")->second, "deferred");
  EXPECT_EQ(q.find("width")->second, "320");
  EXPECT_EQ(q.find("device")->second, "llvmpipe (LLVM)");
  EXPECT_EQ(q.find("limit")->second, "2");
  EXPECT_EQ(q.count("height"), 0u);

  auto all = api.listAllRuns(f, 2);
  ASSERT_TRUE(all) << all.error();
  auto runs = runList(*all);
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runView(runs[2]).id, "9");
  RunView r = runView(runs[0]);
  EXPECT_EQ(r.renderer, "visbuffer");
  EXPECT_EQ(r.capture, "7");
  EXPECT_EQ(r.samples, 2);
  EXPECT_DOUBLE_EQ(*r.frameMs, 1.834);
}

TEST(ApiClient, SampleReadWriteSumsCounters) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url()});
  auto sample = api.getSample("101");
  ASSERT_TRUE(sample) << sample.error();
  auto [read, written] = sampleReadWrite(*sample);
  EXPECT_DOUBLE_EQ(read, 2048 + 1048576);
  EXPECT_DOUBLE_EQ(written, 1024);
}

TEST(ApiClient, CompareView) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url()});
  auto res = api.compare({"12", "15"});
  ASSERT_TRUE(res) << res.error();
  CompareView c = compareView(*res);
  ASSERT_EQ(c.runs.size(), 2u);
  ASSERT_GE(c.rows.size(), 5u);
  EXPECT_EQ(c.rows[0].metric, "ms");
  EXPECT_DOUBLE_EQ(*c.rows[0].values[1].ratio, 0.75);
  const CompareRow& last = c.rows.back();
  EXPECT_EQ(last.resource, "gbuffer.normal (write)");
  EXPECT_FALSE(last.values[1].value);
}

TEST(ApiClient, ExportIsVerbatim) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url()});
  RunFilters f;
  f.capture = "7";
  auto csv = api.exportRuns("csv", f);
  ASSERT_TRUE(csv) << csv.error();
  EXPECT_EQ(*csv, "run_id,renderer,bytes\n12,deferred,3145728\n");
  EXPECT_EQ(fake.lastExportQuery().find("capture")->second, "7");
}

TEST(ApiClient, ServerFromEnvironment) {
  ::setenv(kServerEnv, "http://example.invalid:1/", 1);
  EXPECT_EQ(resolveServer(""), "http://example.invalid:1");
  EXPECT_EQ(resolveServer("http://127.0.0.1:9"), "http://127.0.0.1:9");
  ::unsetenv(kServerEnv);
  EXPECT_EQ(resolveServer(""), defaultServer());
}

TEST(ApiClient, ToleratesStringIdsAndNumericProgress) {
  JobView j = jobView(json::parse(R"({"id":"j7","status":"running","progress":0.25,"extra":{"x":1}})"));
  EXPECT_EQ(j.id, "j7");
  EXPECT_DOUBLE_EQ(*j.fraction, 0.25);
  EXPECT_FALSE(j.done);
  RunView r = runView(json::parse(R"({"id":"3","device":{"name":"H200"},"summary":{"frame_ms":2.5}})"));
  EXPECT_EQ(r.device, "H200");
  EXPECT_EQ(
      sampleView(json::parse(R"({"camera":{"index":2,"label":"all geometry: eye at (0.1, 0.6) of bounds"}})"))
          .camera,
      "2 all geometry");
  EXPECT_EQ(sampleView(json::parse(R"({"camera":{"index":3,"label":"eye at (0.9, 0.8) of bounds"}})")).camera,
            "3");
  EXPECT_DOUBLE_EQ(*r.frameMs, 2.5);
}

// A fleet's fields: hosts, and a job's host, attempts and why it waits; all
// absent (or null) from a server before hosts.
TEST(ApiClient, HostsAndJobsOfAFleet) {
  FakeTallyd fake;
  ApiClient api({.server = fake.url()});
  auto page = api.listHosts();
  ASSERT_TRUE(page) << page.error();
  auto hosts = hostList(*page);
  ASSERT_EQ(hosts.size(), 3u);
  EXPECT_EQ(staleAfterSeconds(*page), 30.0);
  HostView a = hostView(hosts[0]), b = hostView(hosts[1]), c = hostView(hosts[2]);
  EXPECT_EQ(a.name, "gpu-a");
  EXPECT_EQ(a.role, "worker");
  EXPECT_TRUE(a.probed);
  EXPECT_EQ(a.deviceName, "NVIDIA H100 80GB HBM3");
  EXPECT_EQ(a.deviceVendor, "NVIDIA");
  EXPECT_EQ(a.driver, "550.54.15");
  EXPECT_EQ(a.apiVersion, "1.3.280");
  EXPECT_EQ(a.deviceOverride, "");
  EXPECT_EQ(a.tallyCommit, "abc1234");
  EXPECT_DOUBLE_EQ(*a.secondsSinceHeartbeat, 3.2);
  EXPECT_EQ(a.alive, true);
  EXPECT_EQ(a.jobsDone, 4);
  EXPECT_EQ(a.jobsFailed, 1);
  EXPECT_EQ(a.currentJob, "12");
  EXPECT_EQ(b.deviceOverride, "FakeGPU-A");
  EXPECT_EQ(b.currentJob, "");
  EXPECT_FALSE(c.probed);
  EXPECT_EQ(c.alive, false);

  JobView queued = jobView(*api.getCapture("9"));
  EXPECT_EQ(queued.host, "");
  EXPECT_EQ(queued.attempts, 1);
  EXPECT_EQ(queued.maxAttempts, 3);
  EXPECT_EQ(queued.attemptErrors, std::vector<std::string>{test::kLostAttempt});
  EXPECT_EQ(queued.waiting, test::kWaitingReason);
  JobView running = jobView(*api.getCapture("10"));
  EXPECT_EQ(running.host, "gpu-a");
  EXPECT_EQ(running.waiting, "");

  RunFilters f;
  f.host = "gpu-a";
  auto runs = api.listRuns(f, std::nullopt);
  ASSERT_TRUE(runs) << runs.error();
  EXPECT_EQ(fake.lastRunsQuery().find("host")->second, "gpu-a");
  EXPECT_EQ(runView(runList(*runs).at(0)).host, "gpu-a");

  // Before hosts: none of the fields.
  JobView old = jobView(json::parse(R"({"id":7,"status":"queued","attempts":0})"));
  EXPECT_EQ(old.host, "");
  EXPECT_FALSE(old.maxAttempts);
  EXPECT_TRUE(old.attemptErrors.empty());
  EXPECT_EQ(old.waiting, "");
  EXPECT_EQ(runView(json::parse(R"({"id":3,"host":null})")).host, "");
}

// fails_at comes keyed by the swept parameter, or as one list of groups
// (a sweep of one axis); either way one row per group, with the value where
// it fails or none where it holds.
TEST(ApiClient, FailsAtRowsPerGroup) {
  json byAxis = {{"distance", {{{"near", 0.01}, {"far", 1000}, {"distance", 300}}}},
                 {"far_over_near", {{{"distance", 3}, {"far", 1000}, {"far_over_near", nullptr}}}},
                 {"near", nullptr}};
  auto rows = failsAtRows(byAxis, {"near", "far", "distance"});
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].swept, "distance");
  EXPECT_EQ(rows[0].group, "far=1000 near=0.01");
  EXPECT_EQ(rows[0].value, "300");
  EXPECT_EQ(rows[1].swept, "far_over_near");
  EXPECT_EQ(rows[1].group, "distance=3 far=1000");
  EXPECT_EQ(rows[1].value, "");  // holds
  EXPECT_EQ(rows[2].swept, "near");  // no group of this axis fails
  EXPECT_EQ(rows[2].value, "");

  // A list: the swept parameter is the last parameter every group has as a number or null.
  json list = {{{"selection", "first_lane"}, {"cell_size", 8}}, {{"selection", "uniform"}, {"cell_size", nullptr}}};
  rows = failsAtRows(list, {"selection", "cell_size"});
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].swept, "cell_size");
  EXPECT_EQ(rows[0].group, "selection=first_lane");
  EXPECT_EQ(rows[0].value, "8");
  EXPECT_EQ(rows[1].group, "selection=uniform");
  EXPECT_EQ(rows[1].value, "");
  EXPECT_TRUE(failsAtRows(nullptr, {"near"}).empty());

  EXPECT_EQ(pointValue({{"error", {{"max_relative", 2e-5}}}}, "error.max_relative"), 2e-5);
  EXPECT_TRUE(pointValue({{"error", 1}}, "error.max_relative").is_null());
}

TEST(Tables, AlignsColumns) {
  Table t({{"ID", Table::Align::Right}, {"NAME"}});
  t.addRow({"7", "deferred"});
  t.addRow({"123", "forward"});
  EXPECT_EQ(t.str(), " ID  NAME\n  7  deferred\n123  forward\n");
}

TEST(Tables, NumberFormats) {
  EXPECT_EQ(humanBytes(1023.0), "1023 B");
  EXPECT_EQ(humanBytes(1536.0), "1.50 KiB");
  EXPECT_EQ(humanBytes(1048576.0), "1.00 MiB");
  EXPECT_EQ(humanBytes(std::optional<double>()), "-");
  EXPECT_EQ(percent(0.31), "31.0%");
  EXPECT_EQ(ratio(1.1), "1.10x");
  EXPECT_EQ(signedBytes(-2048.0), "-2.00 KiB");
  EXPECT_EQ(signedFixed(0.5, 2), "+0.50");
  EXPECT_EQ(ago(3.2), "3 s ago");
  EXPECT_EQ(ago(-0.5), "0 s ago");  // clocks apart
  EXPECT_EQ(ago(89.9), "89 s ago");
  EXPECT_EQ(ago(125.0), "2 min ago");
  EXPECT_EQ(ago(3 * 3600.0 + 5), "3 h ago");
  EXPECT_EQ(ago(3 * 86400.0), "3 d ago");
  EXPECT_EQ(ago(std::nullopt), "-");
  EXPECT_EQ(progressLine(0.3, 12, 40, "deferred atrium 320x180 camera 3", 10),
            "[###.......] 12/40 deferred atrium 320x180 camera 3");
}

}  // namespace
}  // namespace tally::client

// The Prometheus text format as written by metrics::Registry, checked line by
// line against the format's rules (cumulative buckets, +Inf = _count, label
// escaping). tests/service/metrics_test.py parses a live daemon's /metrics
// with Debian's python3-prometheus-client as the second, independent reader.
#include "common/metrics.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace tally::metrics {
namespace {

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

bool has(const std::string& text, const std::string& line) {
  for (const auto& l : lines(text)) {
    if (l == line) return true;
  }
  return false;
}

TEST(Metrics, CounterAndGaugeLines) {
  Registry r;
  r.declare("jobs_total", Type::kCounter, "Jobs ended");
  r.declare("queue", Type::kGauge, "Jobs waiting");
  r.add("jobs_total", {{"status", "done"}});
  r.add("jobs_total", {{"status", "done"}}, 2);
  r.add("jobs_total", {{"status", "failed"}});
  r.set("queue", {}, 7);
  r.set("queue", {}, 3);  // a gauge keeps the last value
  std::string t = r.text();
  EXPECT_TRUE(has(t, "# HELP jobs_total Jobs ended")) << t;
  EXPECT_TRUE(has(t, "# TYPE jobs_total counter")) << t;
  EXPECT_TRUE(has(t, "jobs_total{status=\"done\"} 3")) << t;
  EXPECT_TRUE(has(t, "jobs_total{status=\"failed\"} 1")) << t;
  EXPECT_TRUE(has(t, "# TYPE queue gauge")) << t;
  EXPECT_TRUE(has(t, "queue 3")) << t;
  EXPECT_EQ(r.value("jobs_total", {{"status", "done"}}), 3);
  EXPECT_EQ(r.value("jobs_total", {{"status", "never"}}), 0);
}

TEST(Metrics, HistogramBucketsAreCumulativeAndEndInInf) {
  Registry r;
  r.declare("latency_seconds", Type::kHistogram, "Latency", {0.1, 1, 10});
  for (double v : {0.05, 0.1, 0.5, 2.0, 20.0}) r.observe("latency_seconds", {{"route", "/a"}}, v);
  std::string t = r.text();
  // le is inclusive: 0.1 falls in the 0.1 bucket.
  EXPECT_TRUE(has(t, "latency_seconds_bucket{route=\"/a\",le=\"0.1\"} 2")) << t;
  EXPECT_TRUE(has(t, "latency_seconds_bucket{route=\"/a\",le=\"1\"} 3")) << t;
  EXPECT_TRUE(has(t, "latency_seconds_bucket{route=\"/a\",le=\"10\"} 4")) << t;
  EXPECT_TRUE(has(t, "latency_seconds_bucket{route=\"/a\",le=\"+Inf\"} 5")) << t;
  EXPECT_TRUE(has(t, "latency_seconds_count{route=\"/a\"} 5")) << t;
  EXPECT_TRUE(has(t, "latency_seconds_sum{route=\"/a\"} 22.65")) << t;
  EXPECT_EQ(r.value("latency_seconds", {{"route", "/a"}}), 5);
}

TEST(Metrics, LabelValuesAreEscaped) {
  Registry r;
  r.declare("device_info", Type::kGauge, "Device\nname");
  r.set("device_info", {{"device", "a \"b\" \\c\nd"}}, 1);
  std::string t = r.text();
  EXPECT_TRUE(has(t, "# HELP device_info Device\\nname")) << t;
  EXPECT_TRUE(has(t, "device_info{device=\"a \\\"b\\\" \\\\c\\nd\"} 1")) << t;
}

TEST(Metrics, ScrapeCollectorsRunBeforeEachText) {
  Registry r;
  r.declare("size_bytes", Type::kGauge, "Size");
  int scrapes = 0;
  r.onScrape([&](Registry& m) { m.set("size_bytes", {}, ++scrapes * 100); });
  EXPECT_TRUE(has(r.text(), "size_bytes 100"));
  EXPECT_TRUE(has(r.text(), "size_bytes 200"));
}

TEST(Metrics, ClearDropsAGaugesSamples) {
  Registry r;
  r.declare("info", Type::kGauge, "Info");
  r.set("info", {{"device", ""}}, 1);
  r.clear("info");
  r.set("info", {{"device", "llvmpipe"}}, 1);
  std::string t = r.text();
  EXPECT_FALSE(has(t, "info{device=\"\"} 1")) << t;
  EXPECT_TRUE(has(t, "info{device=\"llvmpipe\"} 1")) << t;
}

TEST(Metrics, MisuseIsAProgrammingError) {
  Registry r;
  r.declare("x_total", Type::kCounter, "X");
  EXPECT_THROW(r.declare("x_total", Type::kCounter, "again"), std::logic_error);
  EXPECT_THROW(r.set("x_total", {}, 1), std::logic_error);  // a counter is not set
  EXPECT_THROW(r.add("undeclared_total", {}), std::logic_error);
}

}  // namespace
}  // namespace tally::metrics

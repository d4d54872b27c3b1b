// service/trace.hpp: a stored sample as Chrome trace-event JSON, checked
// against the format's documented fields (the Trace Event Format: name, ph,
// ts, dur, pid, tid, args; complete events "X" with dur >= 0, counters "C"
// with numeric args, metadata "M" naming processes and threads) and the
// layout docs/api.md gives: frames end to end, passes nested in them.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "service/trace.hpp"

namespace tally::service {
namespace {

using nlohmann::json;

store::Counter counter(const std::string& resource, const std::string& access, double bytes) {
  store::Counter c;
  c.resource = resource;
  c.access = access;
  c.bytes = bytes;
  c.count = bytes / 4;
  c.source = "counter";
  return c;
}

store::RunRow run() {
  store::RunRow r;
  r.id = 7;
  r.renderer = "deferred";
  r.variant = "deferred gbuffer=subpass";
  r.scene = "atrium";
  r.width = 320;
  r.height = 180;
  r.counting = "exact";
  r.deviceName = "llvmpipe";
  r.host = "gpu-a";
  return r;
}

// Two passes over three frames; per-frame times stored unless `medians`.
store::Sample sample(bool perFrame) {
  store::Sample s;
  s.row.id = 42;
  s.row.runId = 7;
  s.row.frames = 3;
  s.row.frameMs = 2.0;
  store::Pass gbuffer;
  gbuffer.name = "gbuffer";
  gbuffer.gpuMs = 0.75;
  gbuffer.counters = {counter("gbuffer.normal", "write", 1000), counter("material_maps.diffuse", "read", 500)};
  store::Pass lighting;
  lighting.name = "lighting";
  lighting.gpuMs = 1.0;
  lighting.counters = {counter("gbuffer.normal", "read", 800)};
  if (perFrame) {
    s.row.frameMsFrames = {2.0, 1.5, 3.25};
    gbuffer.gpuMsFrames = {0.75, 0.5, 1.25};
    lighting.gpuMsFrames = {1.0, 1.0, 2.5};  // frame 2: 1.25 + 2.5 > 3.25, cut at the frame's end
  }
  s.passes = {gbuffer, lighting};
  return s;
}

int64_t ns(const json& micros) { return std::llround(micros.get<double>() * 1000.0); }

// Every event has the documented fields of its phase.
void expectWellFormed(const json& trace) {
  ASSERT_TRUE(trace.is_object());
  ASSERT_TRUE(trace["traceEvents"].is_array());
  EXPECT_EQ(trace["displayTimeUnit"], "ms");
  EXPECT_TRUE(trace["metadata"].is_object());
  for (const auto& e : trace["traceEvents"]) {
    SCOPED_TRACE(e.dump());
    ASSERT_TRUE(e["name"].is_string());
    ASSERT_TRUE(e["ph"].is_string());
    ASSERT_TRUE(e["pid"].is_number_integer());
    ASSERT_TRUE(e["tid"].is_number_integer());
    ASSERT_TRUE(e["ts"].is_number());
    EXPECT_GE(e["ts"].get<double>(), 0.0);
    ASSERT_TRUE(e["args"].is_object());
    std::string ph = e["ph"];
    ASSERT_TRUE(ph == "X" || ph == "C" || ph == "M");
    if (ph == "X") {
      ASSERT_TRUE(e["dur"].is_number());
      EXPECT_GE(e["dur"].get<double>(), 0.0);
    } else {
      EXPECT_FALSE(e.contains("dur"));
    }
    if (ph == "C") {
      EXPECT_FALSE(e["args"].empty());
      for (const auto& [key, value] : e["args"].items()) EXPECT_TRUE(value.is_number()) << key;
    }
    if (ph == "M") {
      EXPECT_TRUE(e["name"] == "process_name" || e["name"] == "thread_name");
      EXPECT_TRUE(e["args"]["name"].is_string());
    }
  }
}

std::vector<json> events(const json& trace, const std::string& ph, const std::string& cat = "") {
  std::vector<json> out;
  for (const auto& e : trace["traceEvents"]) {
    if (e["ph"] == ph && (cat.empty() || e.value("cat", "") == cat)) out.push_back(e);
  }
  return out;
}

TEST(SampleTrace, FollowsTheTraceEventFormat) {
  json trace = sampleTrace(run(), sample(true));
  expectWellFormed(trace);
  auto names = events(trace, "M");
  ASSERT_EQ(names.size(), 2u);
  std::map<std::string, std::string> named;
  for (const auto& m : names) named[m["name"]] = m["args"]["name"];
  EXPECT_EQ(named["thread_name"], "GPU");
  EXPECT_EQ(named["process_name"], "deferred gbuffer=subpass atrium 320x180 on llvmpipe (gpu-a)");
  EXPECT_EQ(trace["metadata"]["frame_times"], "measured");
  EXPECT_EQ(trace["metadata"]["sample"], 42);
  EXPECT_EQ(trace["metadata"]["run"], 7);
  EXPECT_EQ(trace["metadata"]["frames"], 3);
}

// Frames laid end to end with the measured times; each pass inside its
// frame, end to end from the frame's start, lasting its time in that frame
// (cut at the frame's end where it would overrun it); slices on the one
// track nest properly.
TEST(SampleTrace, FramesEndToEndPassesNestedInThem) {
  json trace = sampleTrace(run(), sample(true));
  auto frames = events(trace, "X", "frame");
  ASSERT_EQ(frames.size(), 3u);
  const std::vector<int64_t> frameNs = {2000000, 1500000, 3250000};
  int64_t at = 0;
  for (size_t f = 0; f < 3; ++f) {
    EXPECT_EQ(frames[f]["name"], "frame " + std::to_string(f));
    EXPECT_EQ(ns(frames[f]["ts"]), at);
    EXPECT_EQ(ns(frames[f]["dur"]), frameNs[f]);
    at += frameNs[f];
  }
  auto passes = events(trace, "X", "pass");
  ASSERT_EQ(passes.size(), 6u);
  const std::vector<std::pair<int64_t, int64_t>> expected = {
      {0, 750000},       {750000, 1000000},  // frame 0
      {2000000, 500000}, {2500000, 1000000},  // frame 1
      {3500000, 1250000}, {4750000, 2000000}};  // frame 2: lighting's 2.5 ms cut to the 2 ms left
  for (size_t i = 0; i < passes.size(); ++i) {
    SCOPED_TRACE(passes[i].dump());
    EXPECT_EQ(passes[i]["name"], i % 2 ? "lighting" : "gbuffer");
    EXPECT_EQ(ns(passes[i]["ts"]), expected[i].first);
    EXPECT_EQ(ns(passes[i]["dur"]), expected[i].second);
  }
  EXPECT_DOUBLE_EQ(passes[5]["args"]["gpu_ms"].get<double>(), 2.5);  // the measured time is kept
  EXPECT_EQ(trace["metadata"]["clipped_passes"], 1);

  // Proper nesting on the track: sorted by start (longer first), every slice
  // ends before the enclosing one does, or starts after it ended.
  std::vector<std::pair<int64_t, int64_t>> slices;
  for (const auto& e : events(trace, "X")) slices.push_back({ns(e["ts"]), ns(e["ts"]) + ns(e["dur"])});
  std::sort(slices.begin(), slices.end(), [](auto a, auto b) {
    return a.first != b.first ? a.first < b.first : a.second > b.second;
  });
  std::vector<int64_t> open;  // ends of the enclosing slices
  for (const auto& [start, end] : slices) {
    while (!open.empty() && open.back() <= start) open.pop_back();
    if (!open.empty()) {
      EXPECT_LE(end, open.back()) << "slice [" << start << ", " << end << ") overlaps its parent";
    }
    open.push_back(end);
  }
}

// Counters: one series per resource, bytes per frame (read + write over
// every pass), at each frame's start.
TEST(SampleTrace, BytesPerResourceAsCounters) {
  json trace = sampleTrace(run(), sample(true));
  auto counters = events(trace, "C");
  ASSERT_EQ(counters.size(), 6u);  // 2 resources x 3 frames
  std::map<std::string, std::vector<std::pair<int64_t, double>>> series;
  for (const auto& c : counters) series[c["name"]].push_back({ns(c["ts"]), c["args"]["bytes"].get<double>()});
  ASSERT_EQ(series.size(), 2u);
  const std::vector<int64_t> starts = {0, 2000000, 3500000};
  for (size_t f = 0; f < 3; ++f) {
    EXPECT_EQ(series["bytes gbuffer.normal"][f], std::make_pair(starts[f], 1800.0));
    EXPECT_EQ(series["bytes material_maps.diffuse"][f], std::make_pair(starts[f], 500.0));
  }
}

// Without stored per-frame times: the sample's frames, each at the medians.
TEST(SampleTrace, MediansWhenPerFrameTimesAreAbsent) {
  json trace = sampleTrace(run(), sample(false));
  expectWellFormed(trace);
  EXPECT_EQ(trace["metadata"]["frame_times"], "medians");
  auto frames = events(trace, "X", "frame");
  ASSERT_EQ(frames.size(), 3u);
  for (size_t f = 0; f < 3; ++f) {
    EXPECT_EQ(ns(frames[f]["ts"]), int64_t(f) * 2000000);
    EXPECT_EQ(ns(frames[f]["dur"]), 2000000);
  }
  auto passes = events(trace, "X", "pass");
  ASSERT_EQ(passes.size(), 6u);
  for (size_t i = 0; i < passes.size(); ++i) {
    EXPECT_EQ(ns(passes[i]["dur"]), i % 2 ? 1000000 : 750000);
  }
  EXPECT_EQ(trace["metadata"]["clipped_passes"], 0);

  // A pass whose per-frame times are missing makes the whole trace medians.
  store::Sample partial = sample(true);
  partial.passes[1].gpuMsFrames.clear();
  EXPECT_EQ(sampleTrace(run(), partial)["metadata"]["frame_times"], "medians");
}

}  // namespace
}  // namespace tally::service

// analysis/repeats: grouping by configuration, across-run figures, the noise
// band and count identity, on hand-made runs whose figures are worked out in
// the comments (dyadic numbers, so every comparison is exact in doubles).
#include <gtest/gtest.h>

#include "analysis/repeats.hpp"

namespace {
using namespace tally::analysis;

RepeatRun makeRun(const std::string& id, std::vector<double> frameMs, std::vector<double> iqrs, int width = 64) {
  RepeatRun run;
  run.id = id;
  run.renderer = "deferred";
  run.scene = "atrium";
  run.sceneParams = "{}";
  run.device = "1";
  run.counting = "exact";
  run.width = width;
  run.height = 36;
  run.lights = 400;
  for (size_t i = 0; i < frameMs.size(); ++i) {
    RepeatSample s;
    s.camera = "{\"eye\":[" + std::to_string(i) + ",0,0]}";
    s.frames = 20;
    s.frameMs = frameMs[i];
    s.frameMsIqr = iqrs[i];
    s.bytes = 1000.0 * double(i + 1);
    s.counts = {{"gbuffer/gbuffer.normal write", 2304.0 * double(i + 1)}, {"lighting/lights read", 921600.0}};
    run.samples.push_back(std::move(s));
  }
  return run;
}

TEST(Repeats, FiguresAndBand) {
  // Per-run medians over samples: a {1, 3, 2} -> 2; b {2.5, 2, 2.25} -> 2.25;
  // c {1.75, 1.5, 2} -> 1.75. Across runs, sorted {1.75, 2, 2.25}: median 2,
  // q1 = 1.75 + 0.5 x 0.25 = 1.875, q3 = 2.125. Within-run IQRs pooled,
  // sorted {0.125, 0.25 x5, 0.5 x2, 0.75}: median 0.25, so the band is
  // [2 - 0.25, 2 + 0.25] = [1.75, 2.25] and both ends are inside it.
  std::vector<RepeatRun> runs = {makeRun("a", {1, 3, 2}, {0.25, 0.5, 0.75}),
                                 makeRun("b", {2.5, 2, 2.25}, {0.125, 0.25, 0.5}),
                                 makeRun("c", {1.75, 1.5, 2}, {0.25, 0.25, 0.25})};
  auto groups = repeatGroups(runs);
  ASSERT_EQ(groups.size(), 1u);
  const auto& g = groups[0];
  ASSERT_EQ(g.runs.size(), 3u);
  EXPECT_EQ(g.runs[0]->id, "a");
  EXPECT_EQ(g.runs[2]->id, "c");
  EXPECT_EQ(g.frameMs.perRun, (std::vector<double>{2, 2.25, 1.75}));
  EXPECT_EQ(g.frameMs.across.median, 2);
  EXPECT_EQ(g.frameMs.across.q1, 1.875);
  EXPECT_EQ(g.frameMs.across.q3, 2.125);
  EXPECT_EQ(g.frameMs.across.min, 1.75);
  EXPECT_EQ(g.frameMs.across.max, 2.25);
  EXPECT_EQ(g.frameMs.noise, 0.25);
  EXPECT_EQ(g.frameMs.low, 1.75);
  EXPECT_EQ(g.frameMs.high, 2.25);
  EXPECT_TRUE(g.frameMs.agrees);
  // Bytes: per-run mean of {1000, 2000, 3000} = 2000 in every run, no noise:
  // they agree because they are equal.
  EXPECT_EQ(g.bytes.perRun, (std::vector<double>{2000, 2000, 2000}));
  EXPECT_EQ(g.bytes.noise, 0);
  EXPECT_TRUE(g.bytes.agrees);
  EXPECT_TRUE(g.counts.identical);
  EXPECT_EQ(g.counts.counters, 6u);  // 3 cameras x 2 counters
  EXPECT_EQ(g.counts.firstDifference, "");

  // c's median 1.5 lies 0.5 below the new across-run median 2 (sorted
  // {1.5, 2, 2.25}); the noise is still 0.25, so the band [1.75, 2.25]
  // leaves it out.
  runs[2] = makeRun("c", {1.5, 1.25, 2}, {0.25, 0.25, 0.25});
  groups = repeatGroups(runs);
  ASSERT_EQ(groups.size(), 1u);
  EXPECT_EQ(groups[0].frameMs.perRun[2], 1.5);
  EXPECT_EQ(groups[0].frameMs.across.median, 2);
  EXPECT_EQ(groups[0].frameMs.noise, 0.25);
  EXPECT_FALSE(groups[0].frameMs.agrees);
}

TEST(Repeats, BytesDisagreeWithoutNoise) {
  // Exact counts have no frame-to-frame noise: one byte more is a disagreement.
  std::vector<RepeatRun> runs = {makeRun("a", {1, 1}, {0, 0}), makeRun("b", {1, 1}, {0, 0})};
  runs[1].samples[1].bytes += 1;
  runs[1].samples[0].bytes += 1;
  auto groups = repeatGroups(runs);
  ASSERT_EQ(groups.size(), 1u);
  // Per run: mean of {1000, 2000} = 1500 and of {1001, 2001} = 1501; median 1500.5.
  EXPECT_EQ(groups[0].bytes.perRun, (std::vector<double>{1500, 1501}));
  EXPECT_EQ(groups[0].bytes.across.median, 1500.5);
  EXPECT_FALSE(groups[0].bytes.agrees);
  EXPECT_TRUE(groups[0].frameMs.agrees);  // equal times, zero noise
}

TEST(Repeats, ConfigurationDecidesTheGroups) {
  std::vector<RepeatRun> runs = {makeRun("a", {1}, {0}), makeRun("wide", {1}, {0}, 96), makeRun("b", {1}, {0}),
                                 makeRun("frames", {1}, {0}), makeRun("camera", {1}, {0}), makeRun("lights", {1}, {0}),
                                 makeRun("alone", {1}, {0}, 128)};
  runs[3].samples[0].frames = 10;
  runs[4].samples[0].camera = "{\"eye\":[9,0,0]}";
  runs[5].lights = 100;
  auto groups = repeatGroups(runs);
  ASSERT_EQ(groups.size(), 1u);
  ASSERT_EQ(groups[0].runs.size(), 2u);
  EXPECT_EQ(groups[0].runs[0]->id, "a");
  EXPECT_EQ(groups[0].runs[1]->id, "b");
  // A run without samples is no repeat, even of another empty run.
  EXPECT_TRUE(repeatGroups({makeRun("e", {}, {}), makeRun("f", {}, {})}).empty());
}

TEST(Repeats, CountsMustBeIdentical) {
  std::vector<RepeatRun> runs = {makeRun("a", {1, 1}, {0, 0}), makeRun("b", {1, 1}, {0, 0})};
  runs[1].samples[1].counts["lighting/lights read"] = 921601;
  auto groups = repeatGroups(runs);
  ASSERT_EQ(groups.size(), 1u);
  EXPECT_FALSE(groups[0].counts.identical);
  EXPECT_EQ(groups[0].counts.firstDifference, "run b camera 1: lighting/lights read: 921600 != 921601");

  runs[1] = makeRun("b", {1, 1}, {0, 0});
  runs[1].samples[0].counts["extra/x read"] = 1;
  groups = repeatGroups(runs);
  EXPECT_FALSE(groups[0].counts.identical);
  EXPECT_EQ(groups[0].counts.firstDifference, "run b camera 0: extra/x read: absent != 1");
}

TEST(Repeats, FromResult) {
  // Two runs of one result: bytes are summed over lines, the bytes noise is
  // each counter's count IQR x its bytes per count (2 x 8 + 0), frame noise
  // the frame_ms_spread IQR.
  nlohmann::json sample = {
      {"camera", {{"eye", {0, 1, 2}}, {"index", 0}, {"label", "x"}}},
      {"frames", 20},
      {"frame_ms", 1.5},
      {"frame_ms_spread", {{"median", 1.5}, {"q1", 1.25}, {"q3", 2.0}, {"iqr", 0.75}, {"n", 20}}},
      {"passes",
       {{{"name", "gbuffer"},
         {"resources",
          {{{"name", "gbuffer.normal"}, {"access", "write"}, {"count", 100}, {"bytes", 800}, {"count_spread", {{"iqr", 2}}}},
           {{"name", "gbuffer.depth"}, {"access", "write"}, {"count", 100}, {"bytes", 500}}}}}}}};
  nlohmann::json result = {{"device", {{"name", "llvmpipe"}}},
                           {"runs",
                            {{{"renderer", "deferred"}, {"scene", "atrium"}, {"width", 64}, {"height", 36}, {"lights", 4},
                              {"samples", {sample}}},
                             {{"renderer", "forward"}, {"scene", "atrium"}, {"width", 64}, {"height", 36}, {"lights", 4},
                              {"samples", {sample}}}}}};
  auto runs = repeatRunsFromResult(result, "a.json");
  ASSERT_TRUE(runs) << runs.error();
  ASSERT_EQ(runs->size(), 2u);
  const auto& s = (*runs)[0].samples.at(0);
  EXPECT_EQ((*runs)[1].id, "a.json#1");
  EXPECT_EQ((*runs)[0].device, "llvmpipe");
  EXPECT_EQ((*runs)[0].counting, "exact");
  EXPECT_EQ(s.camera, "{\"eye\":[0,1,2]}");
  EXPECT_EQ(s.frames, 20);
  EXPECT_EQ(s.frameMsIqr, 0.75);
  EXPECT_EQ(s.bytes, 1300);
  EXPECT_EQ(s.bytesIqr, 16);
  EXPECT_EQ(s.counts.at("gbuffer/gbuffer.normal write"), 100);
  // Different renderers: no group; the same result twice: two groups of two.
  EXPECT_TRUE(repeatGroups(*runs).empty());
  auto twice = *runs;
  twice.insert(twice.end(), runs->begin(), runs->end());
  EXPECT_EQ(repeatGroups(twice).size(), 2u);
  EXPECT_FALSE(repeatRunsFromResult(nlohmann::json::object(), "x"));
}

// A run's frame time is the median of all its frames (frame_ms_median, as
// every view shows it), not the median of its cameras' medians.
// Camera 0: {1, 2, 3} (median 2); camera 1: {4, 8, 9, 10, 11} (median 9).
// Their medians' median is 5.5; the eight frames sorted are
// {1, 2, 3, 4, 8, 9, 10, 11}: median (4 + 8) / 2 = 6. With n = 8,
// k = floor(4 - 0.98 sqrt 8) = floor(1.228) = 1: the interval is the 1st and
// 8th order statistics, [1, 11].
TEST(Repeats, RunFrameTimeIsTheMedianOfAllFrames) {
  RepeatRun run = makeRun("a", {2, 9}, {1, 2});
  run.samples[0].frameTimes = {3, 1, 2};
  run.samples[1].frameTimes = {10, 4, 11, 9, 8};
  RunFrameMs t = runFrameMs(run);
  EXPECT_EQ(t.source, "frames");
  EXPECT_EQ(t.median, 6);
  EXPECT_EQ(t.frames, 8u);
  EXPECT_EQ(t.lower, 1);
  EXPECT_EQ(t.upper, 11);

  // Seven frames: k = floor(3.5 - 0.98 sqrt 7) = 0, no interval.
  run.samples[1].frameTimes = {10, 4, 11, 9};
  t = runFrameMs(run);
  EXPECT_EQ(t.median, 4);
  EXPECT_EQ(t.frames, 7u);
  EXPECT_FALSE(t.lower);
  EXPECT_FALSE(t.upper);

  // A camera without per-frame times (a run stored before they were kept):
  // the median of the cameras' medians, (2 + 9) / 2, without an interval.
  run.samples[1].frameTimes.clear();
  t = runFrameMs(run);
  EXPECT_EQ(t.source, "samples");
  EXPECT_EQ(t.median, 5.5);
  EXPECT_EQ(t.frames, 0u);
  EXPECT_FALSE(t.lower);
  EXPECT_EQ(runFrameMs(makeRun("none", {}, {})).source, "none");
}

// The group's per-run frame time is each run's median of all frames; the
// spread and band are over those values. Run a as above (6, interval [1, 11]);
// run b: camera 0 {2, 2, 3}, camera 1 {6, 6, 7, 7, 7}: sorted
// {2, 2, 3, 6, 6, 7, 7, 7}, median 6, interval [2, 7]. Per-sample IQRs
// {1, 2} and {0.5, 0.5}: noise median 0.75, band [5.25, 6.75].
TEST(Repeats, GroupUsesTheRunsFrameTime) {
  std::vector<RepeatRun> runs = {makeRun("a", {2, 9}, {1, 2}), makeRun("b", {2, 7}, {0.5, 0.5})};
  runs[0].samples[0].frameTimes = {3, 1, 2};
  runs[0].samples[1].frameTimes = {10, 4, 11, 9, 8};
  runs[1].samples[0].frameTimes = {2, 2, 3};
  runs[1].samples[1].frameTimes = {6, 6, 7, 7, 7};
  auto groups = repeatGroups(runs);
  ASSERT_EQ(groups.size(), 1u);
  const auto& g = groups[0];
  EXPECT_EQ(g.frameMs.statistic, "frame_ms_median");
  EXPECT_EQ(g.frameMs.perRun, (std::vector<double>{6, 6}));
  EXPECT_EQ(g.frameMs.across.median, 6);
  EXPECT_EQ(g.frameMs.noise, 0.75);
  EXPECT_EQ(g.frameMs.low, 5.25);
  EXPECT_EQ(g.frameMs.high, 6.75);
  EXPECT_TRUE(g.frameMs.agrees);
  nlohmann::json j = frameMsJson(g);
  EXPECT_EQ(j["statistic"], "frame_ms_median");
  EXPECT_EQ(j["per_run"], (nlohmann::json{6.0, 6.0}));
  EXPECT_EQ(j["per_run_lower"], (nlohmann::json{1.0, 2.0}));
  EXPECT_EQ(j["per_run_upper"], (nlohmann::json{11.0, 7.0}));
  EXPECT_EQ(j["per_run_source"], (nlohmann::json{"frames", "frames"}));
  EXPECT_EQ(toJson(g.bytes)["statistic"], "mean_bytes");

  // Without per-frame times, the cameras' medians: a (2 + 9) / 2, b (2 + 7) / 2.
  for (auto& run : runs)
    for (auto& sample : run.samples) sample.frameTimes.clear();
  groups = repeatGroups(runs);
  EXPECT_EQ(groups[0].frameMs.perRun, (std::vector<double>{5.5, 4.5}));
  EXPECT_EQ(frameMsJson(groups[0])["per_run_lower"], (nlohmann::json{nullptr, nullptr}));
  EXPECT_EQ(frameMsJson(groups[0])["per_run_source"], (nlohmann::json{"samples", "samples"}));
}

TEST(Repeats, FromResultKeepsEveryFrame) {
  nlohmann::json sample = {{"camera", {{"eye", {0, 1, 2}}}},
                           {"frames", 3},
                           {"frame_ms", 2.0},
                           {"frame_ms_frames", {2.0, 1.0, 4.0}},
                           {"passes", nlohmann::json::array()}};
  nlohmann::json old = sample;
  old.erase("frame_ms_frames");
  nlohmann::json result = {{"device", {{"name", "llvmpipe"}}},
                           {"runs",
                            {{{"renderer", "deferred"},
                              {"scene", "atrium"},
                              {"width", 64},
                              {"height", 36},
                              {"samples", {sample, old}}}}}};
  auto runs = repeatRunsFromResult(result, "a.json");
  ASSERT_TRUE(runs) << runs.error();
  EXPECT_EQ((*runs)[0].samples.at(0).frameTimes, (std::vector<double>{2, 1, 4}));
  EXPECT_TRUE((*runs)[0].samples.at(1).frameTimes.empty());
}

}  // namespace

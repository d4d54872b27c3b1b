// reports::runSignificance over stored runs of known frame-time
// distributions: a run built 15% slower is called slower with an interval
// that covers 1.15, a run drawn from the same distribution is the same, one
// changed counter is the one change reported, repeated captures with their
// own offsets widen the interval by the spread of their medians (computed
// here independently), and runs without per-frame times or with zero pass
// times say why instead of failing.
#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "../store/store_fixture.hpp"
#include "reports/frame_time.hpp"
#include "reports/run_significance.hpp"

namespace {
namespace st = tally::store::testing;
using nlohmann::json;
using tally::analysis::Verdict;
using tally::reports::runSignificance;
using tally::reports::SignificanceOptions;

constexpr int kCameras = 3;
constexpr int kFrames = 20;

struct RunShape {
  double scale = 1.0;        // every time multiplied by this
  bool passZero = false;     // the "lights" pass reads 0 ms in every frame
  bool perFrame = true;      // store frame_ms_frames and gpu_ms_frames
  double lightsCount = 1000; // the lights pass's counter
  int firstCamera = 0;       // cameras firstCamera .. firstCamera + cameras - 1
  int cameras = kCameras;
  int frames = kFrames;
};

// Lognormal frame times around 4 ms + 1 ms per camera index (sigma of log
// 0.05), split 30/70 into the passes "gbuffer" and "lights".
json runOf(std::mt19937_64& rng, const RunShape& shape) {
  std::lognormal_distribution<double> noise(0.0, 0.05);
  std::vector<json> samples;
  for (int c = shape.firstCamera; c < shape.firstCamera + shape.cameras; ++c) {
    std::vector<double> frames, gbuffer, lights;
    for (int f = 0; f < shape.frames; ++f) {
      double t = (4.0 + c) * noise(rng) * shape.scale;
      frames.push_back(t);
      gbuffer.push_back(0.3 * t);
      lights.push_back(shape.passZero ? 0.0 : 0.7 * t);
    }
    auto median = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
    };
    json g = st::makePass("gbuffer", median(gbuffer), 1000, {st::makeCounter("gbuffer.normal", "write", 500, 4000)});
    json l = st::makePass("lights", median(lights), 1000,
                          {st::makeCounter("gbuffer.normal", "read", shape.lightsCount, shape.lightsCount * 8)});
    if (shape.perFrame) {
      g["gpu_ms_frames"] = gbuffer;
      l["gpu_ms_frames"] = lights;
    }
    json s = st::makeSample(c, median(frames), {g, l});
    s["camera"]["eye"] = {double(c), 2.0, 3.0};
    s["frames"] = shape.frames;
    if (shape.perFrame) s["frame_ms_frames"] = frames;
    samples.push_back(std::move(s));
  }
  return st::makeRun("deferred", "atrium", 320, 180, std::move(samples));
}

class RunSignificance : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = st::openStore(db_.path());
    ASSERT_NE(store_, nullptr);
  }
  // Stores one capture of one run; returns the run's id.
  int64_t store(const json& run) {
    auto job = store_->jobs().create({{"renderers", {"deferred"}}});
    EXPECT_TRUE(job) << job.error();
    auto stored = store_->runs().ingestCapture(job->job.id, st::makeCapture({run}), {});
    EXPECT_TRUE(stored) << stored.error();
    EXPECT_TRUE(store_->jobs().finish(job->job.id, tally::store::JobStatus::Done));
    tally::store::RunFilter filter;
    filter.jobId = job->job.id;
    auto runs = store_->runs().list(filter, {});
    EXPECT_TRUE(runs && runs->runs.size() == 1);
    return runs->runs.front().id;
  }
  st::TempDb db_;
  std::unique_ptr<tally::store::Store> store_;
  std::mt19937_64 rng_{20261125};
};

SignificanceOptions framesOnly() {
  SignificanceOptions o;
  o.acrossCapture = false;
  return o;
}

TEST_F(RunSignificance, SlowerRunIsSlowerWithAnIntervalCoveringItsFactor) {
  int64_t a = store(runOf(rng_, {}));
  int64_t b = store(runOf(rng_, {.scale = 1.15}));
  auto s = runSignificance(*store_, a, b, framesOnly());
  ASSERT_TRUE(s) << s.error();
  EXPECT_EQ(s->cameras.size(), size_t(kCameras));
  ASSERT_TRUE(s->frame);
  EXPECT_EQ(s->frame->time.nA, size_t(kCameras * kFrames));
  EXPECT_EQ(s->frame->time.verdict, Verdict::Slower) << s->frame->time.reason;
  EXPECT_LT(s->frame->time.interval.lower, 1.15);
  EXPECT_GT(s->frame->time.interval.upper, 1.15);
  EXPECT_LT(s->frame->time.test.pValue, 0.05);
  ASSERT_EQ(s->passes.size(), 2u);
  EXPECT_EQ(s->passes[0].figure, "gbuffer");
  EXPECT_EQ(s->passes[1].figure, "lights");
  for (const auto& p : s->passes) EXPECT_EQ(p.time.verdict, Verdict::Slower) << p.figure;
  // Same counters: three lines and the total, none changed.
  EXPECT_EQ(s->countLines, 3u);
  EXPECT_FALSE(s->countsChanged());
  // And the other way round.
  auto back = runSignificance(*store_, b, a, framesOnly());
  ASSERT_TRUE(back && back->frame);
  EXPECT_EQ(back->frame->time.verdict, Verdict::Faster);
}

// /api/compare reads each run and its samples once and compares the loaded
// runs: the same answer as by ids, and an absent run is no run, not an error.
TEST_F(RunSignificance, LoadedRunsAnswerAsTheirIds) {
  int64_t a = store(runOf(rng_, {}));
  int64_t b = store(runOf(rng_, {.scale = 1.15}));
  auto loadedA = tally::reports::loadStoredRun(*store_, a);
  auto loadedB = tally::reports::loadStoredRun(*store_, b);
  ASSERT_TRUE(loadedA && *loadedA && loadedB && *loadedB);
  EXPECT_EQ((*loadedA)->run.row.id, a);
  EXPECT_EQ((*loadedA)->samples.size(), size_t(kCameras));
  auto byIds = runSignificance(*store_, a, b, framesOnly());
  auto byRuns = runSignificance(*store_, **loadedA, **loadedB, framesOnly());
  ASSERT_TRUE(byIds && byRuns);
  EXPECT_EQ(tally::reports::toJson(*byRuns), tally::reports::toJson(*byIds));
  auto absent = tally::reports::loadStoredRun(*store_, b + 1000);
  ASSERT_TRUE(absent) << absent.error();
  EXPECT_FALSE(*absent);
}

// Cameras of 4, 5 and 6 ms and B 3% slower in each: aligned per camera the
// difference shows; pooled raw, the cameras' spread hides it. The aligned
// ratio is the ratio of the aligned medians, recomputed here.
TEST_F(RunSignificance, CamerasAsStrataSeeWhatPoolingHides) {
  int64_t a = store(runOf(rng_, {}));
  int64_t b = store(runOf(rng_, {.scale = 1.03}));
  auto aligned = runSignificance(*store_, a, b, framesOnly());
  SignificanceOptions pooledOptions = framesOnly();
  pooledOptions.camerasAsStrata = false;
  auto pooled = runSignificance(*store_, a, b, pooledOptions);
  ASSERT_TRUE(aligned && aligned->frame && pooled && pooled->frame);
  EXPECT_EQ(aligned->frame->time.verdict, Verdict::Slower) << aligned->frame->time.reason;
  EXPECT_EQ(pooled->frame->time.verdict, Verdict::Same) << pooled->frame->time.reason;
  EXPECT_EQ(tally::reports::toJson(*aligned)["frame"]["strata"], "cameras");
  EXPECT_EQ(tally::reports::toJson(*pooled)["frame"]["strata"], "none");

  auto frames = [&](int64_t run) {
    std::vector<std::vector<double>> out;
    auto rows = store_->runs().samples(run);
    for (const auto& row : *rows) out.push_back((**store_->runs().sample(row.id)).row.frameMsFrames);
    return out;
  };
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  auto fa = frames(a), fb = frames(b);
  std::vector<double> all, alignedA, alignedB;
  for (size_t c = 0; c < fa.size(); ++c) {
    all.insert(all.end(), fa[c].begin(), fa[c].end());
    all.insert(all.end(), fb[c].begin(), fb[c].end());
  }
  double grand = median(all);
  for (size_t c = 0; c < fa.size(); ++c) {
    std::vector<double> both = fa[c];
    both.insert(both.end(), fb[c].begin(), fb[c].end());
    double m = median(both);
    for (double t : fa[c]) alignedA.push_back(t * grand / m);
    for (double t : fb[c]) alignedB.push_back(t * grand / m);
  }
  EXPECT_NEAR(aligned->frame->time.ratio, median(alignedB) / median(alignedA), 1e-12);
}

TEST_F(RunSignificance, RunFromTheSameDistributionIsTheSame) {
  int64_t a = store(runOf(rng_, {}));
  int64_t b = store(runOf(rng_, {}));
  auto s = runSignificance(*store_, a, b, framesOnly());
  ASSERT_TRUE(s && s->frame);
  EXPECT_EQ(s->frame->time.verdict, Verdict::Same) << s->frame->time.reason;
  EXPECT_LT(s->frame->time.interval.lower, 1.0);
  EXPECT_GT(s->frame->time.interval.upper, 1.0);
}

TEST_F(RunSignificance, ChangedCounterIsTheOneChangeReported) {
  int64_t a = store(runOf(rng_, {}));
  int64_t b = store(runOf(rng_, {.lightsCount = 1200}));
  auto s = runSignificance(*store_, a, b, framesOnly());
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->countsChanged());
  // The sample bytes (every counter's bytes) and the lights line change; the gbuffer write does not.
  ASSERT_EQ(s->countChanges.size(), 2u);
  EXPECT_EQ(s->countChanges[0].line, "total");
  // Per frame, as every other view shows bytes: the mean over the cameras, not their sum.
  EXPECT_DOUBLE_EQ(s->countChanges[0].b - s->countChanges[0].a, 200.0 * 8);
  EXPECT_EQ(s->countChanges[1].line, "lights/gbuffer.normal read");
  EXPECT_DOUBLE_EQ(s->countChanges[1].a, 1000.0);
  EXPECT_DOUBLE_EQ(s->countChanges[1].b, 1200.0);
  json j = tally::reports::toJson(*s);
  EXPECT_EQ(j["counts"]["verdict"], "changed");
  EXPECT_EQ(j["counts"]["changes"][1]["delta"], 200.0);
}

// Five captures of one configuration, each with its own offset (sigma of log
// 0.08) and tight frames: between captures the frames alone call differences
// real; the repeats' spread widens the interval.
TEST_F(RunSignificance, RepeatedCapturesWidenByTheSpreadOfTheirMedians) {
  std::normal_distribution<double> offset(0.0, 0.08);
  std::vector<int64_t> ids;
  std::vector<double> scales;
  for (int i = 0; i < 5; ++i) {
    double scale = std::exp(offset(rng_));
    // Keep two of them clearly apart so frames alone call a difference.
    if (i == 4) scale = scales[0] * 1.12;
    scales.push_back(scale);
    ids.push_back(store(runOf(rng_, {.scale = scale})));
  }
  auto frames = runSignificance(*store_, ids[0], ids[4], framesOnly());
  ASSERT_TRUE(frames && frames->frame);
  EXPECT_EQ(frames->frame->time.verdict, Verdict::Slower);
  EXPECT_FALSE(frames->frame->acrossCapture);

  auto widened = runSignificance(*store_, ids[0], ids[4]);
  ASSERT_TRUE(widened && widened->frame);
  const auto& across = widened->frame->acrossCapture;
  ASSERT_TRUE(across);
  // The repeats are runs 0..3: B (run 4) is the capture under test.
  std::vector<int64_t> expectedRuns(ids.begin(), ids.begin() + 4);
  std::vector<int64_t> got = across->runs;
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, expectedRuns);
  // One cell per camera and figure (the frame and the passes gbuffer and
  // lights): 3 x 3 cells of 4 captures, 3 degrees of freedom each.
  EXPECT_EQ(across->cells, 9u);
  EXPECT_EQ(across->captures, 4u);
  EXPECT_EQ(across->degreesOfFreedom, 27u);
  // The same standard deviation from the stored samples' own per-frame times.
  std::map<std::string, std::vector<double>> cells;
  auto logMedian = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return std::log(n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
  };
  for (int i = 0; i < 4; ++i) {
    auto rows = store_->runs().samples(ids[i]);
    ASSERT_TRUE(rows);
    for (const auto& row : *rows) {
      auto sample = store_->runs().sample(row.id);
      ASSERT_TRUE(sample && *sample);
      std::string camera = std::to_string(row.cameraIndex);
      cells[camera + " frame"].push_back(logMedian((**sample).row.frameMsFrames));
      for (const auto& pass : (**sample).passes) cells[camera + " " + pass.name].push_back(logMedian(pass.gpuMsFrames));
    }
  }
  ASSERT_EQ(cells.size(), 9u);
  double ss = 0;
  for (const auto& [key, logs] : cells) {
    double mean = (logs[0] + logs[1] + logs[2] + logs[3]) / 4;
    for (double l : logs) ss += (l - mean) * (l - mean);
  }
  EXPECT_NEAR(across->logSd, std::sqrt(ss / 27), 1e-12);
  // Four captures bound the noise: the verdict says nothing about it.
  EXPECT_TRUE(widened->frame->noiseNote.empty()) << widened->frame->noiseNote;
  EXPECT_GT(widened->frame->time.interval.widening, 1.0);
  EXPECT_LT(widened->frame->time.interval.lower, frames->frame->time.interval.lower);
  EXPECT_GT(widened->frame->time.interval.upper, frames->frame->time.interval.upper);
  // The p-value stays the frames' own.
  EXPECT_DOUBLE_EQ(widened->frame->time.test.pValue, frames->frame->time.test.pValue);
}

// Two captures of one configuration that differ by 35% (noisy, as on a busy
// machine) and a third 10x slower. One degree of freedom would put t at 12.7
// and the widened interval past 10x; pooled over the 3 cameras and 3 figures
// the spread has 9, and the slower capture is called slower, with a word that
// two captures are too few to bound the noise.
TEST_F(RunSignificance, TwoNoisyRepeatsStillShowATenfoldSlowdown) {
  int64_t first = store(runOf(rng_, {}));
  int64_t second = store(runOf(rng_, {.scale = 1.35}));
  int64_t slow = store(runOf(rng_, {.scale = 10}));
  auto s = runSignificance(*store_, second, slow);
  ASSERT_TRUE(s && s->frame) << (s ? s->frameMissing : s.error());
  const auto& across = s->frame->acrossCapture;
  ASSERT_TRUE(across);
  std::vector<int64_t> runs = across->runs;
  std::sort(runs.begin(), runs.end());
  EXPECT_EQ(runs, (std::vector<int64_t>{first, second}));
  EXPECT_EQ(across->captures, 2u);
  EXPECT_EQ(across->degreesOfFreedom, 9u);
  // What a single degree of freedom would have done: a half-width past log 10.
  EXPECT_GT(tally::analysis::acrossCaptureHalfWidth(across->logSd, 2, 0.95), std::log(10.0));
  EXPECT_EQ(s->frame->time.verdict, Verdict::Slower) << s->frame->time.reason;
  EXPECT_GT(s->frame->time.interval.lower, 1.0);
  for (const auto& pass : s->passes) EXPECT_EQ(pass.time.verdict, Verdict::Slower) << pass.figure;
  EXPECT_NE(s->frame->time.reason.find("only 2 repeated captures: too few to bound"), std::string::npos)
      << s->frame->time.reason;
  json j = tally::reports::toJson(*s);
  EXPECT_EQ(j["frame"]["noise_note"], s->frame->noiseNote);
  EXPECT_EQ(j["frame"]["across_capture"]["captures"], 2);
  EXPECT_EQ(j["frame"]["across_capture"]["cells"], 9);

  // Without any repeat of either configuration the verdict says so too.
  json fewLights = runOf(rng_, {}), moreLights = runOf(rng_, {.scale = 10});
  fewLights["lights"] = 100;  // two more configurations, each captured once
  moreLights["lights"] = 200;
  auto alone = runSignificance(*store_, store(fewLights), store(moreLights));
  ASSERT_TRUE(alone && alone->frame);
  EXPECT_FALSE(alone->frame->acrossCapture);
  EXPECT_NE(alone->frame->time.reason.find("capture-to-capture noise is not bounded"), std::string::npos)
      << alone->frame->time.reason;
  // Not sought: nothing said.
  auto framesAlone = runSignificance(*store_, slow, first, framesOnly());
  ASSERT_TRUE(framesAlone && framesAlone->frame);
  EXPECT_TRUE(framesAlone->frame->noiseNote.empty());
}

TEST_F(RunSignificance, RunsWithoutPerFrameTimesSayWhy) {
  int64_t a = store(runOf(rng_, {.perFrame = false}));
  int64_t b = store(runOf(rng_, {}));
  auto s = runSignificance(*store_, a, b, framesOnly());
  ASSERT_TRUE(s) << s.error();
  EXPECT_FALSE(s->frame);
  EXPECT_NE(s->frameMissing.find("per-frame times"), std::string::npos) << s->frameMissing;
  EXPECT_TRUE(s->passes.empty());
  EXPECT_EQ(s->passesMissing.size(), 2u);
  EXPECT_FALSE(s->countsChanged());  // counts still compare
}

TEST_F(RunSignificance, ARunOfOneFrameSaysSo) {
  int64_t a = store(runOf(rng_, {.cameras = 1, .frames = 1}));
  int64_t b = store(runOf(rng_, {.cameras = 1}));
  auto s = runSignificance(*store_, a, b, framesOnly());
  ASSERT_TRUE(s) << s.error();
  EXPECT_FALSE(s->frame);
  EXPECT_EQ(s->frameMissing, "sample A has 1 frame time; a comparison needs at least 2");
  auto reversed = runSignificance(*store_, b, a, framesOnly());
  ASSERT_TRUE(reversed) << reversed.error();
  EXPECT_EQ(reversed->frameMissing, "sample B has 1 frame time; a comparison needs at least 2");
}

TEST_F(RunSignificance, ZeroPassTimesAreReportedNotFatal) {
  int64_t a = store(runOf(rng_, {.passZero = true}));
  int64_t b = store(runOf(rng_, {.passZero = true}));
  auto s = runSignificance(*store_, a, b, framesOnly());
  ASSERT_TRUE(s) << s.error();
  ASSERT_TRUE(s->frame);
  ASSERT_EQ(s->passes.size(), 1u);
  EXPECT_EQ(s->passes[0].figure, "gbuffer");
  ASSERT_EQ(s->passesMissing.size(), 1u);
  EXPECT_EQ(s->passesMissing[0].first, "lights");
  EXPECT_NE(s->passesMissing[0].second.find("not positive"), std::string::npos) << s->passesMissing[0].second;
}

TEST_F(RunSignificance, RunsWithoutACommonCameraAreIncomparable) {
  int64_t a = store(runOf(rng_, {}));
  int64_t b = store(runOf(rng_, {.firstCamera = 10}));
  auto s = runSignificance(*store_, a, b);
  ASSERT_TRUE(s) << s.error();
  EXPECT_TRUE(s->cameras.empty());
  EXPECT_NE(s->incomparable.find("no camera in common"), std::string::npos);
  EXPECT_TRUE(tally::reports::toJson(*s).contains("error"));
  auto missing = runSignificance(*store_, a, 9999);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error(), "no run 9999");
}

}  // namespace

namespace {

using tally::reports::runFrameTime;
using tally::store::SampleFrameTimes;

// The one frame time of a run: the median of every frame of every sample,
// with the order-statistic interval; the median of the samples' medians,
// labelled, where a sample has no per-frame times; nothing without samples.
TEST(RunFrameTime, MedianOfEveryFrameOrOfTheSamples) {
  // 1..10 and 11..20 ms: pooled median 10.5, k = floor(10 - 0.98 sqrt(20)) = 5.
  std::vector<SampleFrameTimes> samples(2);
  for (int f = 1; f <= 10; ++f) {
    samples[0].frames.push_back(f);
    samples[1].frames.push_back(10 + f);
  }
  samples[0].frameMs = 5.5;
  samples[1].frameMs = 15.5;
  auto t = runFrameTime(samples);
  EXPECT_EQ(t.source, "frames");
  EXPECT_EQ(t.frames, 20u);
  EXPECT_EQ(t.median, 10.5);
  EXPECT_EQ(t.lower, 5.0);   // the 5th smallest
  EXPECT_EQ(t.upper, 16.0);  // the 16th
  // A third camera of one frame, 40 ms: the mean of the camera medians
  // (20.33) is pulled far above the median of the frames (11).
  samples.push_back({40.0, {40.0}});
  auto skewed = runFrameTime(samples);
  EXPECT_EQ(skewed.median, 11.0);
  // Without the frames of one sample: the median of the samples' medians.
  samples[2].frames.clear();
  auto fallback = runFrameTime(samples);
  EXPECT_EQ(fallback.source, "samples");
  EXPECT_EQ(fallback.median, 15.5);
  EXPECT_FALSE(fallback.lower);
  EXPECT_EQ(fallback.frames, 0u);
  json j = tally::reports::toJson(fallback);
  EXPECT_EQ(j["source"], "samples");
  EXPECT_TRUE(j["lower"].is_null());
  auto none = runFrameTime({});
  EXPECT_EQ(none.source, "none");
  EXPECT_FALSE(none.median);
}

}  // namespace

// ingestCapture: read back what went in, idempotency, atomicity.
#include <algorithm>
#include <limits>
#include <set>

#include "store/batch_insert.hpp"
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

class Ingest : public StoreTest {
 protected:
  // The one sample of the job's one run, read whole; nothing (and a
  // failure) when the job has more or less.
  std::optional<Sample> onlySample(int64_t jobId) {
    auto page = store_->runs().list({.jobId = jobId}, {});
    if (!page || page->runs.size() != 1u) {
      ADD_FAILURE() << "the job has not exactly one run";
      return std::nullopt;
    }
    auto samples = store_->runs().samples(page->runs[0].id);
    if (!samples || samples->size() != 1u) {
      ADD_FAILURE() << "the run has not exactly one sample";
      return std::nullopt;
    }
    auto got = store_->runs().sample((*samples)[0].id);
    if (!got || !got->has_value()) {
      ADD_FAILURE() << "the sample does not read back";
      return std::nullopt;
    }
    return std::move(**got);
  }

  int64_t rowsOfJob(int64_t jobId) {
    std::string job = std::to_string(jobId);
    return scalar(*store_, "SELECT COUNT(*) FROM runs WHERE job_id = " + job) +
           scalar(*store_,
                  "SELECT COUNT(*) FROM samples s JOIN runs r ON r.id = s.run_id WHERE r.job_id = " + job) +
           scalar(*store_,
                  "SELECT COUNT(*) FROM passes p JOIN samples s ON s.id = p.sample_id "
                  "JOIN runs r ON r.id = s.run_id WHERE r.job_id = " +
                      job);
  }
};

TEST_F(Ingest, ReadsBackWhatWentIn) {
  int64_t jobId = newJob();
  Capture c = realisticCapture();
  // A compute pass carries its invocations (migration 0004); the others have none.
  c.result["runs"][1]["samples"][0]["passes"][1]["compute_invocations"] = 57600.0;
  c.result["runs"][1]["samples"][0]["passes"][1]["compute_invocations_statistic"] = 57601.0;
  // A glTF scene's loader notes ride in the run's notes under "scene".
  c.result["runs"][0]["notes"]["scene"] = {"KHR_lights_punctual: used but not implemented; the file's lights are ignored"};
  EXPECT_EQ(ingest(jobId, c), 2);

  auto page = store_->runs().list({.jobId = jobId}, {});
  ASSERT_TRUE(page) << page.error();
  ASSERT_EQ(page->runs.size(), 2u);
  EXPECT_TRUE(page->nextCursor.empty());
  // Newest first: deferred was stored after forward.
  const json& runs = c.result["runs"];
  for (size_t i = 0; i < 2; ++i) {
    const RunRow& row = page->runs[1 - i];
    const json& in = runs[i];
    EXPECT_EQ(row.jobId, jobId);
    EXPECT_EQ(row.renderer, in["renderer"]);
    EXPECT_EQ(row.scene, "atrium");
    EXPECT_EQ(row.sceneParams, in["scene_params"]);
    EXPECT_EQ(row.width, 320);
    EXPECT_EQ(row.height, 180);
    EXPECT_EQ(row.counting, "exact");
    EXPECT_EQ(row.lights, 400);
    EXPECT_EQ(row.notes, in["notes"]);
    if (i == 0) {
      EXPECT_EQ(row.notes["scene"][0], in["notes"]["scene"][0]);
    }
    EXPECT_EQ(row.renderTargetBytes, in["resources"]["render_target_bytes"].get<int64_t>());
    EXPECT_EQ(row.deviceName, c.result["device"]["name"]);
    EXPECT_EQ(row.sampleCount, 2);
    double meanFrame =
        (in["samples"][0]["frame_ms"].get<double>() + in["samples"][1]["frame_ms"].get<double>()) / 2;
    ASSERT_TRUE(row.meanFrameMs);
    EXPECT_DOUBLE_EQ(*row.meanFrameMs, meanFrame);
    EXPECT_FALSE(row.createdAt.empty());

    auto full = store_->runs().get(row.id);
    ASSERT_TRUE(full && full->has_value()) << (full ? "" : full.error());
    const tally::store::Run& run = **full;
    EXPECT_EQ(run.device.name, c.result["device"]["name"]);
    EXPECT_EQ(run.device.vendor, "0x10005");
    EXPECT_EQ(run.device.driver, "Mesa 22.3.6");
    EXPECT_EQ(run.device.apiVersion, "1.3.230");
    EXPECT_EQ(run.device.features, c.result["device"]["features"]);
    EXPECT_EQ(run.device.info, c.result["device"]);
    EXPECT_EQ(run.shaders, c.result["shaders"]);
    ASSERT_EQ(run.resources.size(), 2u);
    EXPECT_EQ(run.resources[0].name, "gbuffer.normal");
    EXPECT_EQ(run.resources[0].format, "R16G16B16A16_SFLOAT");
    EXPECT_EQ(run.resources[0].elementBytes, 8);
    EXPECT_EQ(run.resources[0].allocationBytes, 320 * 180 * 8 + 2048);
    EXPECT_EQ(run.resources[0].formatBytes, 320 * 180 * 8);
    EXPECT_EQ(run.resources[0].usage, "color_attachment|sampled");
    EXPECT_EQ(run.resources[1].kind, "depth");

    auto samples = store_->runs().samples(row.id);
    ASSERT_TRUE(samples);
    ASSERT_EQ(samples->size(), 2u);
    for (size_t s = 0; s < 2; ++s) {
      const json& inSample = in["samples"][s];
      auto got = store_->runs().sample((*samples)[s].id);
      ASSERT_TRUE(got && got->has_value());
      const Sample& sample = **got;
      EXPECT_EQ(sample.row.runId, row.id);
      EXPECT_EQ(sample.row.cameraIndex, static_cast<int>(s));
      EXPECT_EQ(sample.row.camera, inSample["camera"]);
      EXPECT_EQ(sample.row.frames, 20);
      EXPECT_EQ(sample.row.frameMs, inSample["frame_ms"].get<double>());
      EXPECT_EQ(sample.row.frameMsSpread, inSample["frame_ms_spread"]);
      EXPECT_EQ(sample.row.frameMsInstrumented, inSample["frame_ms_instrumented"].get<double>());
      EXPECT_EQ(sample.row.overheadRatio, 1.1);
      EXPECT_EQ(sample.row.skyFractionEstimate, inSample["sky_fraction_estimate"].get<double>());
      if (inSample["sky_fraction"].get<double>() < 0) {
        EXPECT_FALSE(sample.row.skyFraction);
      } else {
        EXPECT_EQ(sample.row.skyFraction, inSample["sky_fraction"].get<double>());
      }
      ASSERT_TRUE(sample.row.imageError);
      EXPECT_EQ(sample.row.imageError->against, "forward");
      EXPECT_EQ(sample.row.imageError->identical, inSample["image_error"]["identical"].get<bool>());
      if (inSample["image_error"]["psnr"].is_null()) {
        EXPECT_FALSE(sample.row.imageError->psnr);
      } else {
        EXPECT_EQ(sample.row.imageError->psnr, inSample["image_error"]["psnr"].get<double>());
      }
      EXPECT_EQ(sample.row.imageError->maxAbs, inSample["image_error"]["max_abs"].get<double>());
      EXPECT_EQ(sample.row.imageError->meanAbs, inSample["image_error"]["mean_abs"].get<double>());
      EXPECT_TRUE(sample.row.hasScreenshot);

      ASSERT_EQ(sample.passes.size(), 4u);
      for (size_t p = 0; p < 4; ++p) {
        const json& inPass = inSample["passes"][p];
        const Pass& pass = sample.passes[p];
        EXPECT_EQ(pass.name, inPass["name"]);
        EXPECT_EQ(pass.gpuMs, inPass["gpu_ms"].get<double>());
        EXPECT_EQ(pass.gpuMsSpread, inPass["gpu_ms_spread"]);
        EXPECT_EQ(pass.gpuMsInstrumented, inPass["gpu_ms_instrumented"].get<double>());
        EXPECT_EQ(pass.overheadRatio, 1.1);
        EXPECT_EQ(pass.fragmentInvocations, inPass["fragment_invocations"].get<double>());
        EXPECT_EQ(pass.fragmentInvocationsStatistic, inPass["fragment_invocations_statistic"].get<double>());
        if (inPass.contains("compute_invocations")) {
          EXPECT_EQ(pass.computeInvocations, inPass["compute_invocations"].get<double>());
          EXPECT_EQ(pass.computeInvocationsStatistic, inPass["compute_invocations_statistic"].get<double>());
        } else {
          EXPECT_FALSE(pass.computeInvocations);
          EXPECT_FALSE(pass.computeInvocationsStatistic);
        }
        ASSERT_EQ(pass.counters.size(), 3u);
        for (size_t k = 0; k < 3; ++k) {
          const json& inCounter = inPass["resources"][k];
          const Counter& counter = pass.counters[k];
          EXPECT_EQ(counter.resource, inCounter["name"]);
          EXPECT_EQ(counter.kind, inCounter["kind"].get<std::string>());
          EXPECT_EQ(counter.format, inCounter["format"].get<std::string>());
          EXPECT_EQ(counter.access, inCounter["access"]);
          EXPECT_EQ(counter.count, inCounter["count"].get<double>());
          EXPECT_EQ(counter.bytes, inCounter["bytes"].get<double>());
          EXPECT_EQ(counter.countSpread, inCounter["count_spread"]);
          EXPECT_EQ(counter.source, inCounter["source"]);
        }
      }
      auto png = store_->runs().screenshot(sample.row.id);
      ASSERT_TRUE(png && png->has_value());
      EXPECT_EQ(**png, c.screenshots.at(inSample["screenshot"].get<std::string>()));
    }
  }
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM screenshots WHERE width = 320 AND height = 180"), 4);
}

// A pass's counters come back exactly as they went in, in order, on both
// engines: names with the characters that COPY and PostgreSQL's array
// literals quote, absent kinds, formats, spreads and footprints, extreme
// numbers, and a pass with no counters (on PostgreSQL they travel as arrays
// on the pass's row, migration 0012).
TEST_F(Ingest, CounterTextsAndAbsentValuesRoundTripExactly) {
  std::vector<json> counters;
  const std::vector<std::string> names = {"quote\"d",  "back\\slash\\",  "{braces},comma", "tab\there",
                                          "new\nline", "NULL",           "\r padded \r\n",     "caf\u00e9 \u2713",
                                          "",          "\\\"{,}\\N"};
  const std::vector<double> numbers = {0.1, 1e-300, 1.7976931348623157e308, 0, 123456789.125, 5e-324,
                                       3.0,  2.5e15,  7.25,                   1.0 / 3};
  for (size_t k = 0; k < names.size(); ++k) {
    json counter = makeCounter(names[k], k % 2 ? "write" : "read", numbers[k], numbers[(k + 3) % numbers.size()]);
    if (k % 3 == 0) counter.erase("kind");
    if (k % 3 == 1) counter["format"] = nullptr;
    counter["count_spread"] = spread(1.5);  // the count's own could overflow to infinity
    if (k % 4 == 0) counter.erase("count_spread");
    if (k % 4 == 1) counter["count_spread"] = {{"note", "a \"quoted\" \\ {spread}"}, {"n", 3}};
    if (k % 2 == 0) counter["footprint_bytes"] = numbers[(k + 5) % numbers.size()];
    counters.push_back(std::move(counter));
  }
  json withCounters = makePass("odd", 1.0, 10, counters);
  json without = makePass("empty", 0.5, 0, {});
  Capture c;
  c.result = makeCapture({makeRun("forward", "atrium", 64, 36, {makeSample(0, 2.0, {withCounters, without})})});
  int64_t jobId = newJob();
  ASSERT_EQ(ingest(jobId, c), 1);
  auto got = onlySample(jobId);
  ASSERT_TRUE(got);
  const Sample& sample = *got;
  ASSERT_EQ(sample.passes.size(), 2u);
  EXPECT_TRUE(sample.passes[1].counters.empty());
  ASSERT_EQ(sample.passes[0].counters.size(), counters.size());
  for (size_t k = 0; k < counters.size(); ++k) {
    SCOPED_TRACE("counter " + std::to_string(k));
    const json& in = counters[k];
    const Counter& out = sample.passes[0].counters[k];
    EXPECT_EQ(out.resource, names[k]);
    EXPECT_EQ(out.access, in["access"]);
    EXPECT_EQ(out.kind, in.contains("kind") ? std::optional<std::string>(in["kind"]) : std::nullopt);
    EXPECT_EQ(out.format, in["format"].is_null() ? std::nullopt : std::optional<std::string>(in["format"]));
    EXPECT_EQ(out.count, in["count"].get<double>());  // bit for bit
    EXPECT_EQ(out.bytes, in["bytes"].get<double>());
    EXPECT_EQ(out.countSpread, in.contains("count_spread") ? in["count_spread"] : json(nullptr));
    EXPECT_EQ(out.source, "counter");
    EXPECT_EQ(out.footprintBytes,
              in.contains("footprint_bytes") ? std::optional<double>(in["footprint_bytes"]) : std::nullopt);
  }
  // The run's per-pass averages read the same counters.
  auto passes = store_->runs().passes(sample.row.runId);
  ASSERT_TRUE(passes && passes->size() == 2u);
  EXPECT_EQ((*passes)[0].counters.size(), counters.size());
  EXPECT_TRUE((*passes)[1].counters.empty());
}

// A spread whose frames all counted the counter's count is stored as its
// frames alone (store/count_spread.hpp) and read back as the object that
// went in, bit for bit; a spread that differs from that in any way (one
// value an ulp off, -0.0, an integer where a float was, a key more or less,
// n not an unsigned integer) is stored whole.
TEST_F(Ingest, ConstantCountSpreadsAreStoredAsTheirFramesAndReadBackWhole) {
  const double c = 136911.9603947413;
  auto constant = [&](double count) {
    return json{{"iqr", 0.0},   {"max", count}, {"mean", count}, {"median", count},
                {"min", count}, {"q1", count},  {"q3", count},   {"n", 20u}};
  };
  std::vector<std::pair<json, bool>> spreads;  // the spread, and whether it is stored as its frames
  spreads.emplace_back(constant(c), true);
  spreads.emplace_back(constant(0.0), true);
  spreads.emplace_back(json::parse(constant(1e-300).dump()), true);  // as a result's text parses
  json integerFrames = constant(c);
  integerFrames["n"] = 7;  // a signed integer, as code that builds JSON may write it
  spreads.emplace_back(integerFrames, true);
  json offByAnUlp = constant(c);
  offByAnUlp["q3"] = std::nextafter(c, 1e300);
  spreads.emplace_back(offByAnUlp, false);
  json negativeZero = constant(c);
  negativeZero["iqr"] = -0.0;
  spreads.emplace_back(negativeZero, false);
  json integerValue = constant(3.0);
  integerValue["max"] = 3;
  spreads.emplace_back(integerValue, false);
  json extraKey = constant(c);
  extraKey["note"] = "kept";
  spreads.emplace_back(extraKey, false);
  json missingKey = constant(c);
  missingKey.erase("mean");
  spreads.emplace_back(missingKey, false);
  json fractionalFrames = constant(c);
  fractionalFrames["n"] = 20.0;
  spreads.emplace_back(fractionalFrames, false);
  json negativeFrames = constant(c);
  negativeFrames["n"] = -20;
  spreads.emplace_back(negativeFrames, false);
  spreads.emplace_back(constant(c + 1), false);  // constant, but not the counter's count

  std::vector<json> counters;
  for (size_t k = 0; k < spreads.size(); ++k) {
    double count = spreads[k].first.contains("median") ? spreads[k].first["median"].get<double>() : c;
    if (k == spreads.size() - 1) count = c;
    json counter = makeCounter("line" + std::to_string(k), "read", count, count * 4);
    counter["count_spread"] = spreads[k].first;
    counters.push_back(std::move(counter));
  }
  Capture capture;
  capture.result = makeCapture(
      {makeRun("forward", "atrium", 64, 36, {makeSample(0, 2.0, {makePass("p", 1.0, 10, counters)})})});
  int64_t jobId = newJob();
  ASSERT_EQ(ingest(jobId, capture), 1);

  // As stored: the frames, or the text.
  Statement stored(store_->connection(), "SELECT count_spread FROM counters ORDER BY position");
  for (size_t k = 0; k < spreads.size(); ++k) {
    SCOPED_TRACE("spread " + std::to_string(k) + ": " + spreads[k].first.dump());
    ASSERT_TRUE(stored.step());
    json text = json::parse(stored.getText(0));
    if (spreads[k].second) {
      EXPECT_EQ(text, spreads[k].first["n"]);
    } else {
      EXPECT_EQ(text.dump(), spreads[k].first.dump());
    }
  }
  EXPECT_FALSE(stored.step());

  // As read: the object that went in, to the byte.
  auto got = onlySample(jobId);
  ASSERT_TRUE(got);
  const auto& read = got->passes.at(0).counters;
  ASSERT_EQ(read.size(), spreads.size());
  for (size_t k = 0; k < spreads.size(); ++k) {
    SCOPED_TRACE("spread " + std::to_string(k));
    EXPECT_EQ(read[k].countSpread.dump(), spreads[k].first.dump());
  }
}

TEST_F(Ingest, MissingThingsAreEmptyNotErrors) {
  auto run = store_->runs().get(424242);
  ASSERT_TRUE(run);
  EXPECT_FALSE(run->has_value());
  auto sample = store_->runs().sample(424242);
  ASSERT_TRUE(sample);
  EXPECT_FALSE(sample->has_value());
  auto png = store_->runs().screenshot(424242);
  ASSERT_TRUE(png);
  EXPECT_FALSE(png->has_value());
  auto samples = store_->runs().samples(424242);
  ASSERT_TRUE(samples);
  EXPECT_TRUE(samples->empty());
}

// The roofline: device.ceilings and each pass's roofline reach the sample's
// extras.roofline (per run: the device row keeps only the latest device
// object), and getRun returns the run's ceilings; runs without them get null.
TEST_F(Ingest, RooflineIsKeptPerRun) {
  int64_t first = newJob();
  Capture c = realisticCapture();
  json ceilings = {{"bandwidth_bytes_per_s", 5.0e9}, {"arithmetic_ops_per_s", 6.0e10}, {"ridge_intensity", 12.0},
                   {"copy_bytes", 67108864}, {"method", {{"timing", "timestamps"}}}};
  c.result["device"]["ceilings"] = ceilings;
  json& pass = c.result["runs"][0]["samples"][0]["passes"][0];
  pass["roofline"] = {{"arithmetic_ops", 1.5e6}, {"bytes_requested", pass["bytes"].is_number() ? pass["bytes"] : json(1e5)},
                      {"fraction_of_peak_bandwidth", 0.25}};
  EXPECT_EQ(ingest(first, c), 2);
  // A second capture on the same device, without ceilings or rooflines.
  int64_t second = newJob();
  EXPECT_EQ(ingest(second, realisticCapture()), 2);

  auto firstRuns = store_->runs().list({.jobId = first}, {});
  ASSERT_TRUE(firstRuns) << firstRuns.error();
  const RunRow& withRoofline = firstRuns->runs[1];  // newest first: runs[0] of the result is last
  auto run = store_->runs().get(withRoofline.id);
  ASSERT_TRUE(run && run->has_value());
  EXPECT_EQ((*run)->ceilings, ceilings);
  auto samples = store_->runs().samples(withRoofline.id);
  ASSERT_TRUE(samples) << samples.error();
  const json& roofline = (*samples)[0].extras["roofline"];
  EXPECT_EQ(roofline["ceilings"], ceilings);
  const std::string name = pass["name"];
  EXPECT_EQ(roofline["passes"][name]["arithmetic_ops"], 1.5e6);
  EXPECT_EQ(roofline["passes"][name]["fraction_of_peak_bandwidth"], 0.25);
  EXPECT_EQ(roofline["passes"][name]["gpu_ms"], pass["gpu_ms"]);
  EXPECT_EQ(roofline["passes"].size(), 1u);  // only the pass that had one
  // The sample without a roofline pass keeps its extras as they were.
  EXPECT_FALSE((*samples)[1].extras.contains("roofline"));

  auto secondRuns = store_->runs().list({.jobId = second}, {});
  ASSERT_TRUE(secondRuns);
  auto plain = store_->runs().get(secondRuns->runs[1].id);
  ASSERT_TRUE(plain && plain->has_value());
  EXPECT_TRUE((*plain)->ceilings.is_null());
  // detail() reads the ceilings in the device's statement: the same answers.
  auto detailed = store_->runs().detail(withRoofline.id);
  ASSERT_TRUE(detailed && detailed->has_value()) << (detailed ? "" : detailed.error());
  EXPECT_EQ((*detailed)->run.ceilings, ceilings);
  auto plainDetailed = store_->runs().detail(secondRuns->runs[1].id);
  ASSERT_TRUE(plainDetailed && plainDetailed->has_value());
  EXPECT_TRUE((*plainDetailed)->run.ceilings.is_null());
}

TEST_F(Ingest, SampleWithoutScreenshotOrImageError) {
  int64_t jobId = newJob();
  Capture c = realisticCapture();
  c.result["runs"][1]["samples"][1]["screenshot"] = nullptr;
  c.result["runs"][1]["samples"][1].erase("image_error");
  ingest(jobId, c);
  auto page = store_->runs().list({.renderer = "deferred", .jobId = jobId}, {});
  ASSERT_TRUE(page && page->runs.size() == 1);
  auto samples = store_->runs().samples(page->runs[0].id);
  ASSERT_TRUE(samples && samples->size() == 2);
  EXPECT_FALSE((*samples)[1].hasScreenshot);
  EXPECT_FALSE((*samples)[1].imageError);
  auto png = store_->runs().screenshot((*samples)[1].id);
  ASSERT_TRUE(png);
  EXPECT_FALSE(png->has_value());
}

// A variant run: its options, label, a sample's extras and variant_error come
// back as they went in; a run without them reads as its renderer, {} and none.
TEST_F(Ingest, VariantRunRoundTrips) {
  int64_t jobId = newJob();
  Capture c = realisticCapture();
  json& run = c.result["runs"][1];
  const std::string renderer = run["renderer"].get<std::string>();
  const json options = {{"barycentrics", "float32"}};
  const std::string label = renderer + " barycentrics=float32";
  run["options"] = options;
  run["variant"] = label;
  const json extras = {{"overdraw", {{"histogram", {1, 2, 3}}, {"mean", 1.5}}}};
  const json variantError = {{"against", renderer}, {"psnr", 38.25}, {"identical", false}, {"max_abs", 9},
                             {"mean_abs", 0.5}};
  run["samples"][0]["extras"] = extras;
  run["samples"][0]["variant_error"] = variantError;
  ingest(jobId, c);

  auto page = store_->runs().list({.renderer = renderer, .variant = label, .jobId = jobId}, {});
  ASSERT_TRUE(page) << page.error();
  ASSERT_EQ(page->runs.size(), 1u);
  EXPECT_EQ(page->runs[0].options, options);
  EXPECT_EQ(page->runs[0].variant, label);
  auto samples = store_->runs().samples(page->runs[0].id);
  ASSERT_TRUE(samples && samples->size() >= 2);
  EXPECT_EQ((*samples)[0].extras, extras);
  ASSERT_TRUE((*samples)[0].variantError);
  EXPECT_EQ((*samples)[0].variantError->against, renderer);
  EXPECT_FALSE((*samples)[0].variantError->identical);
  ASSERT_TRUE((*samples)[0].variantError->psnr);
  EXPECT_EQ(*(*samples)[0].variantError->psnr, 38.25);
  EXPECT_EQ((*samples)[0].variantError->maxAbs, 9);
  EXPECT_EQ((*samples)[0].variantError->meanAbs, 0.5);
  EXPECT_EQ((*samples)[1].extras, json::object());
  EXPECT_FALSE((*samples)[1].variantError);

  // The run without options is its renderer.
  const std::string plain = c.result["runs"][0]["renderer"].get<std::string>();
  auto plainPage = store_->runs().list({.variant = plain, .jobId = jobId}, {});
  ASSERT_TRUE(plainPage) << plainPage.error();
  ASSERT_EQ(plainPage->runs.size(), 1u);
  EXPECT_EQ(plainPage->runs[0].options, json::object());
  EXPECT_EQ(plainPage->runs[0].variant, plain);

  // variant_error names its reference: no implied one.
  Capture bad = realisticCapture();
  bad.result["runs"][0]["samples"][0]["variant_error"] = {{"psnr", 30}, {"max_abs", 1}, {"mean_abs", 0.1}};
  auto refused = store_->runs().ingestCapture(newJob(), bad.result, bad.screenshots);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().find("runs[0].samples[0].variant_error.against"), std::string::npos) << refused.error();
}

TEST_F(Ingest, IngestingTwiceStoresOnce) {
  int64_t jobId = newJob();
  Capture c = realisticCapture();
  ingest(jobId, c);
  auto counts = [&] {
    return std::vector<int64_t>{scalar(*store_, "SELECT COUNT(*) FROM runs"),
                                scalar(*store_, "SELECT COUNT(*) FROM samples"),
                                scalar(*store_, "SELECT COUNT(*) FROM passes"),
                                scalar(*store_, "SELECT COUNT(*) FROM counters"),
                                scalar(*store_, "SELECT COUNT(*) FROM run_resources"),
                                scalar(*store_, "SELECT COUNT(*) FROM screenshots"),
                                scalar(*store_, "SELECT COUNT(*) FROM devices"),
                                scalar(*store_, "SELECT COUNT(*) FROM scenes")};
  };
  auto once = counts();
  EXPECT_EQ(once, (std::vector<int64_t>{2, 4, 16, 48, 4, 4, 1, 1}));
  ingest(jobId, c);
  EXPECT_EQ(counts(), once);
  // Another job with the same device and scene reuses both rows.
  ingest(newJob(), realisticCapture(1));
  EXPECT_EQ(counts(), (std::vector<int64_t>{4, 8, 32, 96, 8, 8, 1, 1}));
}

TEST_F(Ingest, FailureMidwayLeavesNothing) {
  int64_t jobId = newJob();
  Capture c = realisticCapture();
  // The last sample is malformed: everything before it must be rolled back.
  c.result["runs"][1]["samples"][1]["passes"][3]["resources"][2].erase("bytes");
  auto stored = store_->runs().ingestCapture(jobId, c.result, c.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[1].samples[1].passes[3].resources[2].bytes: missing"),
            std::string::npos)
      << stored.error();
  EXPECT_EQ(rowsOfJob(jobId), 0);
  for (const char* table :
       {"runs", "samples", "passes", "counters", "run_resources", "screenshots", "devices", "scenes"}) {
    EXPECT_EQ(scalar(*store_, std::string("SELECT COUNT(*) FROM ") + table), 0) << table;
  }
}

// A pass refused after others went to the server (on PostgreSQL they go in
// pieces through one open COPY while the rest is read): the copy is
// abandoned, nothing of the capture stays, the error names the field, and
// the connection takes the next capture.
TEST_F(Ingest, PassRefusedAfterOthersWereSentLeavesNothing) {
  std::vector<json> samples;
  for (int s = 0; s < 40; ++s) {
    std::vector<json> passes;
    for (int p = 0; p < 4; ++p) {
      passes.push_back(makePass("pass" + std::to_string(p), 1.0 + p, 100,
                                {makeCounter("color", "write", 10.0 + s, 40.0), makeCounter("depth", "read", 5, 20)}));
    }
    samples.push_back(makeSample(s, 2.0, passes));
  }
  Capture c;
  c.result = makeCapture({makeRun("forward", "atrium", 64, 36, samples)});
  // The 160th pass of 160: read after the first 128 were sent.
  c.result["runs"][0]["samples"][39]["passes"][3]["resources"][1]["access"] = "both";
  int64_t jobId = newJob();
  auto stored = store_->runs().ingestCapture(jobId, c.result, c.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[0].samples[39].passes[3].resources[1].access: must be"), std::string::npos)
      << stored.error();
  for (const char* table : {"runs", "samples", "passes", "counters", "run_resources"}) {
    EXPECT_EQ(scalar(*store_, std::string("SELECT COUNT(*) FROM ") + table), 0) << table;
  }
  c.result["runs"][0]["samples"][39]["passes"][3]["resources"][1]["access"] = "read";
  ASSERT_EQ(ingest(jobId, c), 1);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM passes"), 160);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM counters"), 320);
}

// Every table is sent in pieces while the next is read: a sample refused
// after 64 samples' rows were sent, and a screenshot refused after 16
// screenshots were, leave nothing stored either, and the connection takes
// the corrected capture.
TEST_F(Ingest, SampleOrScreenshotRefusedAfterOthersWereSentLeavesNothing) {
  Capture c;
  std::vector<json> runs;
  for (int r = 0; r < 3; ++r) {
    std::vector<json> samples;
    for (int s = 0; s < 30; ++s) {
      std::string shot = "r" + std::to_string(r) + "s" + std::to_string(s) + ".png";
      samples.push_back(makeSample(s, 2.0 + s, {makePass("opaque", 1.0, 100, {makeCounter("color", "write", 10, 40)})},
                                   shot));
      c.screenshots[shot] = fakePng(8, 8, static_cast<uint8_t>(s));
    }
    runs.push_back(makeRun("forward", "atrium", 64, 36, samples));
  }
  c.result = makeCapture(runs);
  int64_t jobId = newJob();
  auto nothingStored = [&](const std::string& why) {
    for (const char* table : {"runs", "samples", "passes", "counters", "run_resources", "screenshots"}) {
      EXPECT_EQ(scalar(*store_, std::string("SELECT COUNT(*) FROM ") + table), 0) << table << " after " << why;
    }
  };
  // The 81st sample of 90: its row is read after 64 were sent.
  c.result["runs"][2]["samples"][20]["image_error"]["identical"] = "yes";
  auto stored = store_->runs().ingestCapture(jobId, c.result, c.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[2].samples[20].image_error.identical: must be true or false"), std::string::npos)
      << stored.error();
  nothingStored("a sample refused");
  c.result["runs"][2]["samples"][20]["image_error"]["identical"] = false;
  // The 61st screenshot of 90, after 60 were sent: not a PNG.
  c.screenshots["r2s0.png"] = {1, 2, 3};
  stored = store_->runs().ingestCapture(jobId, c.result, c.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[2].samples[0].screenshot"), std::string::npos) << stored.error();
  nothingStored("a screenshot refused");
  c.screenshots["r2s0.png"] = fakePng(8, 8, 0);
  ASSERT_EQ(ingest(jobId, c), 3);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM samples"), 90);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM screenshots"), 90);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM run_resources"), 6);
}

// Ids reserved by two connections, interleaved, never meet, and each list
// is ascending and as long as asked. PostgreSQL hands samples', passes' and
// screenshots' ids out in blocks of 1,024 (migration 0014), runs' one by one;
// SQLite's come from the largest id under its one writer's lock instead.
TEST_F(Ingest, ReservedIdsNeverMeetAcrossConnections) {
  if (!db_.postgres()) GTEST_SKIP() << "runs in store.postgresql (TALLY_TEST_STORE=postgres)";
  auto other = openStore(db_.path());
  ASSERT_NE(other, nullptr);
  const std::pair<std::string_view, size_t> tables[] = {
      {"runs", 3}, {"samples", 1500}, {"passes", 2049}, {"screenshots", 0}, {"samples", 1}};
  std::set<std::pair<std::string_view, int64_t>> seen;
  for (int round = 0; round < 3; ++round) {
    for (Store* store : {store_.get(), other.get()}) {
      auto ids = detail::reserveIds(&store->connection(), tables);
      ASSERT_EQ(ids.size(), std::size(tables));
      for (size_t t = 0; t < std::size(tables); ++t) {
        SCOPED_TRACE(std::string(tables[t].first) + ", round " + std::to_string(round));
        ASSERT_EQ(ids[t].size(), tables[t].second);
        EXPECT_TRUE(std::is_sorted(ids[t].begin(), ids[t].end()));
        for (int64_t id : ids[t]) EXPECT_TRUE(seen.emplace(tables[t].first, id).second) << id;
      }
    }
  }
  EXPECT_EQ(seen.size(), 6u * (3 + 1500 + 2049 + 1));
}

TEST_F(Ingest, FailedReingestKeepsThePreviousResult) {
  int64_t jobId = newJob();
  ingest(jobId, realisticCapture());
  int64_t before = rowsOfJob(jobId);
  Capture bad = realisticCapture(7);
  // A constraint SQLite enforces, not the parser: a camera index twice in a run.
  bad.result["runs"][1]["samples"][1]["camera"]["index"] = 0;
  auto stored = store_->runs().ingestCapture(jobId, bad.result, bad.screenshots);
  ASSERT_FALSE(stored);
  EXPECT_NE(stored.error().find("runs[1].samples[1]"), std::string::npos) << stored.error();
  EXPECT_EQ(rowsOfJob(jobId), before);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM screenshots"), 4);
  // The stored values are the first capture's (seed 0), not the failed one's.
  EXPECT_EQ(scalar(*store_, "SELECT MAX(count) FROM counters"), (0 * 1000 + 100 + 10 + 3) * 4);
}

struct BadInput {
  const char* name;
  std::function<void(Capture&)> spoil;
  const char* error;
};

TEST_F(Ingest, BadInputNamesTheField) {
  const std::vector<BadInput> cases = {
      {"no runs", [](Capture& c) { c.result.erase("runs"); }, "runs: missing"},
      {"no device", [](Capture& c) { c.result.erase("device"); }, "device: missing"},
      {"width text", [](Capture& c) { c.result["runs"][0]["width"] = "wide"; },
       "runs[0].width: must be an integer"},
      {"width zero", [](Capture& c) { c.result["runs"][1]["width"] = 0; }, "runs[1].width: must be between"},
      {"access",
       [](Capture& c) { c.result["runs"][0]["samples"][0]["passes"][1]["resources"][0]["access"] = "both"; },
       "runs[0].samples[0].passes[1].resources[0].access: must be \"read\" or \"write\""},
      {"gpu_ms", [](Capture& c) { c.result["runs"][0]["samples"][1]["passes"][2]["gpu_ms"] = "fast"; },
       "runs[0].samples[1].passes[2].gpu_ms: must be a number"},
      {"screenshot missing",
       [](Capture& c) {
         c.screenshots.erase(c.result["runs"][1]["samples"][0]["screenshot"].get<std::string>());
       },
       "runs[1].samples[0].screenshot: 'deferred_atrium_320x180_cam0.png' is not among"},
      {"screenshot not png",
       [](Capture& c) {
         c.screenshots[c.result["runs"][0]["samples"][1]["screenshot"].get<std::string>()] = {1, 2, 3};
       },
       "runs[0].samples[1].screenshot: not a PNG"},
      {"camera", [](Capture& c) { c.result["runs"][0]["samples"][0].erase("camera"); },
       "runs[0].samples[0].camera"},
      {"counter not an object",
       [](Capture& c) { c.result["runs"][0]["samples"][1]["passes"][0]["resources"][2] = "color"; },
       "runs[0].samples[1].passes[0].resources[2]: must be an object"},
      {"count text", [](Capture& c) { c.result["runs"][1]["samples"][1]["passes"][2]["resources"][0]["count"] = "9"; },
       "runs[1].samples[1].passes[2].resources[0].count: must be a number"},
      {"footprint negative",
       [](Capture& c) { c.result["runs"][0]["samples"][0]["passes"][3]["resources"][1]["footprint_bytes"] = -4; },
       "runs[0].samples[0].passes[3].resources[1].footprint_bytes: must not be negative"},
      {"kind a number", [](Capture& c) { c.result["runs"][1]["samples"][0]["passes"][1]["resources"][2]["kind"] = 3; },
       "runs[1].samples[0].passes[1].resources[2].kind: must be a string"},
      {"no source", [](Capture& c) { c.result["runs"][0]["samples"][1]["passes"][1]["resources"][0].erase("source"); },
       "runs[0].samples[1].passes[1].resources[0].source: missing"},
      {"count_spread a number",
       [](Capture& c) { c.result["runs"][1]["samples"][0]["passes"][0]["resources"][1]["count_spread"] = 20; },
       "runs[1].samples[0].passes[0].resources[1].count_spread: must be an object"},
  };
  int64_t jobId = newJob();
  for (const auto& test : cases) {
    Capture c = realisticCapture();
    test.spoil(c);
    auto stored = store_->runs().ingestCapture(jobId, c.result, c.screenshots);
    ASSERT_FALSE(stored) << test.name;
    EXPECT_NE(stored.error().find(test.error), std::string::npos) << test.name << ": " << stored.error();
    EXPECT_EQ(rowsOfJob(jobId), 0) << test.name;
  }
  auto unknownJob =
      store_->runs().ingestCapture(9999, realisticCapture().result, realisticCapture().screenshots);
  ASSERT_FALSE(unknownJob);
  EXPECT_NE(unknownJob.error().find("job 9999 not found"), std::string::npos);
}

// Per-frame times (0008): the sample's frame_ms_frames and each pass's
// gpu_ms_frames come back as they went in; a sample or pass without them
// reads back empty (NULL in the store), as rows stored before 0008 do.
TEST_F(Ingest, PerFrameTimesRoundTrip) {
  int64_t jobId = newJob();
  Capture c = realisticCapture();
  json& timed = c.result["runs"][0]["samples"][0];
  timed["frame_ms_frames"] = {1.5, 1.25, 2.0, 0.0};
  for (size_t p = 0; p < timed["passes"].size(); ++p) {
    double base = 0.125 * double(p + 1);
    timed["passes"][p]["gpu_ms_frames"] = {base, base * 2, base * 3, 0.0};
  }
  c.result["runs"][0]["samples"][1]["frame_ms_frames"] = nullptr;  // null: as absent
  ASSERT_EQ(ingest(jobId, c), 2);
  auto page = store_->runs().list({.jobId = jobId}, {});
  ASSERT_TRUE(page) << page.error();
  ASSERT_EQ(page->runs.size(), 2u);
  auto samples = store_->runs().samples(page->runs[1].id);  // forward: stored first
  ASSERT_TRUE(samples) << samples.error();
  ASSERT_EQ(samples->size(), 2u);

  auto first = store_->runs().sample((*samples)[0].id);
  ASSERT_TRUE(first && first->has_value()) << (first ? "" : first.error());
  EXPECT_EQ((*first)->row.frameMsFrames, (std::vector<double>{1.5, 1.25, 2.0, 0.0}));
  ASSERT_EQ((*first)->passes.size(), timed["passes"].size());
  for (size_t p = 0; p < (*first)->passes.size(); ++p) {
    EXPECT_EQ((*first)->passes[p].gpuMsFrames, timed["passes"][p]["gpu_ms_frames"].get<std::vector<double>>()) << p;
  }
  auto second = store_->runs().sample((*samples)[1].id);
  ASSERT_TRUE(second && second->has_value());
  EXPECT_TRUE((*second)->row.frameMsFrames.empty());
  for (const auto& pass : (*second)->passes) EXPECT_TRUE(pass.gpuMsFrames.empty()) << pass.name;
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM samples WHERE frame_ms_frames IS NULL"), 3);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM samples WHERE frame_ms_frames IS NOT NULL"), 1);
}

// A listing's page reads its runs' frame times in one statement: per run,
// what the one-run read gives, in camera order; a run with no sample, or an
// id with no run, has no entry.
TEST_F(Ingest, FrameTimesOfManyRunsAreEachRunsOwn) {
  int64_t jobId = newJob();
  Capture c = realisticCapture();
  c.result["runs"][0]["samples"][0]["frame_ms_frames"] = {1.5, 1.25, 2.0};
  c.result["runs"][0]["samples"][1]["frame_ms_frames"] = {3.0, 4.0};
  c.result["runs"][1]["samples"][1]["frame_ms_frames"] = {0.5};
  ASSERT_EQ(ingest(jobId, c), 2);
  auto page = store_->runs().list({.jobId = jobId}, {});
  ASSERT_TRUE(page) << page.error();
  ASSERT_EQ(page->runs.size(), 2u);
  const int64_t missingRun = page->runs[0].id + 1000;
  std::vector<int64_t> ids = {page->runs[0].id, missingRun, page->runs[1].id};
  auto many = store_->runs().sampleFrameTimes(ids);
  ASSERT_TRUE(many) << many.error();
  EXPECT_EQ(many->size(), 2u);
  EXPECT_EQ(many->count(missingRun), 0u);
  for (int64_t id : {page->runs[0].id, page->runs[1].id}) {
    auto one = store_->runs().sampleFrameTimes(id);
    ASSERT_TRUE(one) << one.error();
    ASSERT_EQ(one->size(), 2u) << id;
    ASSERT_EQ((*many)[id].size(), one->size()) << id;
    for (size_t i = 0; i < one->size(); ++i) {
      EXPECT_EQ((*many)[id][i].frameMs, (*one)[i].frameMs) << id << " " << i;
      EXPECT_EQ((*many)[id][i].frames, (*one)[i].frames) << id << " " << i;
    }
  }
  // Forward, stored first, is the later page entry: its cameras in order.
  EXPECT_EQ((*many)[page->runs[1].id][0].frames, (std::vector<double>{1.5, 1.25, 2.0}));
  EXPECT_EQ((*many)[page->runs[1].id][1].frames, (std::vector<double>{3.0, 4.0}));
  EXPECT_TRUE((*many)[page->runs[0].id][0].frames.empty());
  EXPECT_EQ((*many)[page->runs[0].id][1].frames, (std::vector<double>{0.5}));
  auto none = store_->runs().sampleFrameTimes(std::span<const int64_t>());
  ASSERT_TRUE(none) << none.error();
  EXPECT_TRUE(none->empty());
}

TEST_F(Ingest, BadPerFrameTimesNameTheEntry) {
  const std::vector<BadInput> cases = {
      {"frame times not an array",
       [](Capture& c) { c.result["runs"][0]["samples"][0]["frame_ms_frames"] = 1.5; },
       "runs[0].samples[0].frame_ms_frames: must be an array"},
      {"frame time text",
       [](Capture& c) { c.result["runs"][0]["samples"][1]["frame_ms_frames"] = {1.0, "slow"}; },
       "runs[0].samples[1].frame_ms_frames[1]: must be a number"},
      {"frame time negative",
       [](Capture& c) { c.result["runs"][1]["samples"][0]["frame_ms_frames"] = {1.0, 2.0, -0.5}; },
       "runs[1].samples[0].frame_ms_frames[2]: must not be negative"},
      {"frame time null entry",
       [](Capture& c) { c.result["runs"][0]["samples"][0]["frame_ms_frames"] = {nullptr}; },
       "runs[0].samples[0].frame_ms_frames[0]: must be a number"},
      {"pass time object",
       [](Capture& c) { c.result["runs"][0]["samples"][1]["passes"][2]["gpu_ms_frames"] = {{"ms", 1}}; },
       "runs[0].samples[1].passes[2].gpu_ms_frames: must be an array"},
      {"pass time negative",
       [](Capture& c) { c.result["runs"][1]["samples"][1]["passes"][0]["gpu_ms_frames"] = {0.5, -1e-3}; },
       "runs[1].samples[1].passes[0].gpu_ms_frames[1]: must not be negative"},
      {"pass time not finite",
       [](Capture& c) {
         c.result["runs"][0]["samples"][0]["passes"][1]["gpu_ms_frames"] = {0.5, std::numeric_limits<double>::infinity()};
       },
       "runs[0].samples[0].passes[1].gpu_ms_frames"},
  };
  int64_t jobId = newJob();
  for (const auto& test : cases) {
    Capture c = realisticCapture();
    test.spoil(c);
    auto stored = store_->runs().ingestCapture(jobId, c.result, c.screenshots);
    ASSERT_FALSE(stored) << test.name;
    EXPECT_NE(stored.error().find(test.error), std::string::npos) << test.name << ": " << stored.error();
    EXPECT_EQ(rowsOfJob(jobId), 0) << test.name;
  }
}

}  // namespace
}  // namespace tally::store::testing

// The accuracy computation against figures worked out by hand.
#include <gtest/gtest.h>

#include "analysis/accuracy.hpp"

namespace tally::analysis {
namespace {

RunCounts makeRun(const std::string& id, const std::string& counting, std::vector<SampleCounts> samples) {
  RunCounts r;
  r.id = id;
  r.renderer = "deferred";
  r.scene = "atrium";
  r.sceneParams = "{}";
  r.device = "lavapipe";
  r.counting = counting;
  r.width = 32;
  r.height = 18;
  r.lights = 8;
  r.group = "1";
  r.samples = std::move(samples);
  return r;
}

// Exact: sample 0 has A=100, B=50; sample 1 has A=200, B=100.
// Sampled: sample 0 has A=110, B=40; sample 1 has A=150, B=100 and a line D=5
// the exact run does not have.
RunCounts exactRun() {
  return makeRun("e", "exact", {{"cam0", 1.0, 1.2, {{"p/A read", 100}, {"p/B read", 50}}},
                                {"cam1", 1.0, 1.4, {{"p/A read", 200}, {"p/B read", 100}}}});
}
RunCounts sampledRun() {
  return makeRun("s", "sampled:4", {{"cam0", 2.0, 3.0, {{"p/A read", 110}, {"p/B read", 40}}},
                                    {"cam1", 2.0, 5.0, {{"p/A read", 150}, {"p/B read", 100}, {"q/D write", 5}}}});
}

TEST(Accuracy, HandDerivedFigures) {
  auto a = compareToExact(sampledRun(), exactRun());
  ASSERT_TRUE(a.ok()) << a.error();
  ASSERT_EQ(a->samples.size(), 2u);
  // Sample 0: totals 150 vs 150 cancel; L1 (10 + 10) / 150; worst B: 10 / 50.
  EXPECT_DOUBLE_EQ(a->samples[0].errors.total, 0.0);
  EXPECT_DOUBLE_EQ(a->samples[0].errors.l1, 20.0 / 150.0);
  EXPECT_DOUBLE_EQ(a->samples[0].errors.worst, 0.2);
  EXPECT_EQ(a->samples[0].errors.worstLine, "p/B read");
  EXPECT_DOUBLE_EQ(a->samples[0].overheadRatio, 1.5);
  EXPECT_DOUBLE_EQ(a->samples[0].referenceOverheadRatio, 1.2);
  // Sample 1: 255 vs 300; L1 (50 + 0 + 5) / 300; D is not in the exact run: 1.
  EXPECT_DOUBLE_EQ(a->samples[1].errors.total, 45.0 / 300.0);
  EXPECT_DOUBLE_EQ(a->samples[1].errors.l1, 55.0 / 300.0);
  EXPECT_DOUBLE_EQ(a->samples[1].errors.worst, 1.0);
  EXPECT_EQ(a->samples[1].errors.worstLine, "q/D write");
  EXPECT_DOUBLE_EQ(a->samples[1].overheadRatio, 2.5);
  // The run: 405 vs 450; L1 (20 + 55) / 450; worst from sample 1.
  EXPECT_DOUBLE_EQ(a->errors.total, 45.0 / 450.0);
  EXPECT_DOUBLE_EQ(a->errors.l1, 75.0 / 450.0);
  EXPECT_DOUBLE_EQ(a->errors.worst, 1.0);
  EXPECT_EQ(a->errors.worstLine, "q/D write");
  EXPECT_EQ(a->worstSample, 1u);
  // Medians of two: (1.5 + 2.5) / 2 and (1.2 + 1.4) / 2.
  EXPECT_DOUBLE_EQ(a->overheadRatio, 2.0);
  EXPECT_DOUBLE_EQ(a->referenceOverheadRatio, 1.3);
}

TEST(Accuracy, IdenticalCountsHaveNoError) {
  RunCounts subgroup = exactRun();
  subgroup.counting = "subgroup";
  auto a = compareToExact(subgroup, exactRun());
  ASSERT_TRUE(a.ok()) << a.error();
  EXPECT_EQ(a->errors.total, 0.0);
  EXPECT_EQ(a->errors.l1, 0.0);
  EXPECT_EQ(a->errors.worst, 0.0);
  EXPECT_EQ(a->errors.worstLine, "");
}

TEST(Accuracy, RefusesDifferentFrames) {
  RunCounts other = sampledRun();
  other.samples[1].camera = "cam2";
  EXPECT_FALSE(compareToExact(other, exactRun()).ok());
  other = sampledRun();
  other.lights = 9;
  EXPECT_FALSE(compareToExact(other, exactRun()).ok());
  other = sampledRun();
  other.samples.pop_back();
  EXPECT_FALSE(compareToExact(other, exactRun()).ok());
}

TEST(Accuracy, ReferencePrefersTheSameCapture) {
  RunCounts older = exactRun(), newer = exactRun(), mine = exactRun();
  older.id = "older";
  newer.id = "newer";
  newer.group = "2";
  mine.id = "mine";
  std::vector<RunCounts> runs = {older, mine, newer};
  std::string why;
  RunCounts run = sampledRun();
  auto ref = findReference(run, runs, &why);
  ASSERT_TRUE(ref.has_value()) << why;
  EXPECT_EQ(runs[*ref].id, "mine");  // group 1, the last of that group
  run.group = "3";
  ref = findReference(run, runs, &why);
  ASSERT_TRUE(ref.has_value()) << why;
  EXPECT_EQ(runs[*ref].id, "newer");  // no exact run of group 3: the last one
  run.width = 64;
  EXPECT_FALSE(findReference(run, runs, &why).has_value());
  EXPECT_NE(why.find("same frames"), std::string::npos) << why;
  run.renderer = "forward";
  EXPECT_FALSE(findReference(run, runs, &why).has_value());
  EXPECT_NE(why.find("no exact run of this renderer"), std::string::npos) << why;
}

TEST(Accuracy, FromACaptureResult) {
  // Two passes read the same resource: they stay separate lines.
  auto sample = [](double a, double b, double ms, double msInstrumented) {
    return nlohmann::json{
        {"camera", {{"eye", {0, 1, 2}}, {"target", {0, 0, 0}}, {"fov_deg", 60}, {"index", 0}}},
        {"frame_ms", ms},
        {"frame_ms_instrumented", msInstrumented},
        {"passes",
         {{{"name", "gbuffer"}, {"resources", {{{"name", "tex"}, {"access", "read"}, {"count", a}, {"bytes", 4 * a}}}}},
          {{"name", "lighting"}, {"resources", {{{"name", "tex"}, {"access", "read"}, {"count", b}, {"bytes", 4 * b}}}}}}}};
  };
  auto run = [&](const char* counting, double a, double b, double msInstrumented) {
    return nlohmann::json{{"renderer", "forward"}, {"scene", "atrium"}, {"scene_params", {{"name", "atrium"}}},
                          {"width", 32},          {"height", 18},      {"counting", counting},
                          {"lights", 8},          {"samples", {sample(a, b, 2.0, msInstrumented)}}};
  };
  nlohmann::json result = {{"device", {{"name", "llvmpipe"}}},
                           {"runs", {run("exact", 10, 20, 4.0), run("sampled:4", 12, 18, 3.0), run("subgroup", 10, 20, 5.0)}}};
  auto runs = runCountsFromResult(result);
  ASSERT_TRUE(runs.ok()) << runs.error();
  ASSERT_EQ(runs->size(), 3u);
  EXPECT_EQ((*runs)[0].samples[0].bytes.size(), 2u);
  auto rows = accuracyRows(*runs);
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_TRUE(rows[0].accuracy.has_value()) << rows[0].reason;
  EXPECT_EQ(rows[0].reference->id, "0");
  // Bytes 48 + 72 against 40 + 80: totals cancel, L1 (8 + 8) / 120, worst 8 / 40.
  EXPECT_DOUBLE_EQ(rows[0].accuracy->errors.total, 0.0);
  EXPECT_DOUBLE_EQ(rows[0].accuracy->errors.l1, 16.0 / 120.0);
  EXPECT_DOUBLE_EQ(rows[0].accuracy->errors.worst, 0.2);
  EXPECT_EQ(rows[0].accuracy->errors.worstLine, "gbuffer/tex read");
  EXPECT_DOUBLE_EQ(rows[0].accuracy->overheadRatio, 1.5);
  EXPECT_DOUBLE_EQ(rows[0].accuracy->referenceOverheadRatio, 2.0);
  ASSERT_TRUE(rows[1].accuracy.has_value());
  EXPECT_EQ(rows[1].accuracy->errors.l1, 0.0);
  EXPECT_DOUBLE_EQ(rows[1].accuracy->overheadRatio, 2.5);
  EXPECT_FALSE(runCountsFromResult(nlohmann::json::object()).ok());
}

}  // namespace
}  // namespace tally::analysis

// A sample's JSON from counted and timed frames (capture/sample.hpp), on CPU:
// frames built by hand, as a renderer would report them.
#include <gtest/gtest.h>

#include "capture/sample.hpp"

namespace tally::capture {
namespace {

using nlohmann::json;

renderers::Access access(const std::string& resource, bool write, uint64_t count, uint64_t bytes,
                         int64_t footprint = -1, const std::string& source = "counter") {
  renderers::Access a;
  a.resource = resource;
  a.write = write;
  a.count = count;
  a.bytes = bytes;
  a.footprintBytes = footprint;
  a.source = source;
  return a;
}

renderers::FrameResult frame(std::vector<renderers::Access> gbuffer, std::vector<renderers::Access> lighting) {
  renderers::FrameResult f;
  renderers::PassResult g;
  g.name = "gbuffer";
  g.gpuMs = 0.5;
  g.accesses = std::move(gbuffer);
  renderers::PassResult l;
  l.name = "lighting";
  l.gpuMs = 0.25;
  l.accesses = std::move(lighting);
  f.passes = {g, l};
  return f;
}

const json* line(const json& sample, const std::string& pass, const std::string& resource, const std::string& access) {
  for (const auto& p : sample["passes"]) {
    if (p["name"] != pass) continue;
    for (const auto& r : p["resources"]) {
      if (r["name"] == resource && r["access"] == access) return &r;
    }
  }
  return nullptr;
}

const json& passOf(const json& sample, const std::string& name) {
  for (const auto& p : sample["passes"]) {
    if (p["name"] == name) return p;
  }
  static const json kNone;
  return kNone;
}

// Footprint measured: each line's footprint is the mean over the counted
// frames, reuse is bytes / footprint (null at a footprint of 0), passes and
// the sample sum the lines that have one; a line without one (-1: a derived
// line) has neither field and adds nothing to the sums; bytes are unchanged.
TEST(SampleJson, FootprintPerLinePassAndSample) {
  SampleMeasure m;
  // Two counted frames: the diffuse map's footprint differs between them (1000 and 3000).
  addCounts(m, frame({access("diffuse", false, 100, 4000, 1000), access("depth", true, 50, 200, -1, "derived")},
                     {access("normal", false, 64, 512, 256), access("hdr", true, 10, 40, 0)}));
  addCounts(m, frame({access("diffuse", false, 100, 4000, 3000), access("depth", true, 50, 200, -1, "derived")},
                     {access("normal", false, 64, 512, 256), access("hdr", true, 10, 40, 0)}));
  addTimes(m, frame({}, {}));
  json sample = sampleJson(m, {}, 1, 2);

  const json* diffuse = line(sample, "gbuffer", "diffuse", "read");
  ASSERT_NE(diffuse, nullptr) << sample.dump();
  EXPECT_EQ((*diffuse)["bytes"], 4000.0);
  EXPECT_EQ((*diffuse)["footprint_bytes"], 2000.0);  // (1000 + 3000) / 2
  EXPECT_EQ((*diffuse)["reuse"], 2.0);               // 4000 / 2000

  const json* depth = line(sample, "gbuffer", "depth", "write");
  ASSERT_NE(depth, nullptr);
  EXPECT_EQ((*depth)["bytes"], 200.0);
  EXPECT_FALSE(depth->contains("footprint_bytes"));
  EXPECT_FALSE(depth->contains("reuse"));

  const json* normal = line(sample, "lighting", "normal", "read");
  ASSERT_NE(normal, nullptr);
  EXPECT_EQ((*normal)["footprint_bytes"], 256.0);
  EXPECT_EQ((*normal)["reuse"], 2.0);  // 512 / 256

  const json* hdr = line(sample, "lighting", "hdr", "write");
  ASSERT_NE(hdr, nullptr);
  EXPECT_EQ((*hdr)["footprint_bytes"], 0.0);
  EXPECT_TRUE((*hdr)["reuse"].is_null());  // nothing touched: no ratio

  EXPECT_EQ(passOf(sample, "gbuffer")["footprint_bytes"], 2000.0);  // diffuse only: depth has none
  EXPECT_EQ(passOf(sample, "gbuffer")["bytes"], 4200.0);            // every line, as before
  EXPECT_EQ(passOf(sample, "lighting")["footprint_bytes"], 256.0);
  EXPECT_EQ(sample["footprint_bytes"], 2256.0);
  EXPECT_EQ(sample["bytes"], 4752.0);
}

// Footprint off (every line -1): no footprint field anywhere, the rest as it was.
TEST(SampleJson, NoFootprintFieldsWhenNotMeasured) {
  SampleMeasure m;
  for (int f = 0; f < 2; ++f) {
    addCounts(m, frame({access("diffuse", false, 100, 4000)}, {access("normal", false, 64, 512)}));
    addTimes(m, frame({}, {}));
  }
  json sample = sampleJson(m, {}, 2, 2);
  EXPECT_FALSE(sample.contains("footprint_bytes")) << sample.dump();
  ASSERT_EQ(sample["passes"].size(), 2u);
  for (const auto& p : sample["passes"]) {
    EXPECT_FALSE(p.contains("footprint_bytes")) << p.dump();
    for (const auto& r : p["resources"]) {
      EXPECT_FALSE(r.contains("footprint_bytes")) << r.dump();
      EXPECT_FALSE(r.contains("reuse")) << r.dump();
    }
  }
  EXPECT_EQ(sample["bytes"], 4512.0);
  EXPECT_EQ(sample["frame_ms"], 0.75);
}

// Per-frame times: one entry per uninstrumented frame, in order, aligned
// across passes (0 in a frame a pass did not run in); the medians are the
// reported times.
TEST(SampleJson, PerFrameTimesAlignedWithTheFrames) {
  SampleMeasure m;
  addCounts(m, frame({}, {}));
  for (double scale : {1.0, 3.0, 2.0}) {
    renderers::FrameResult f = frame({}, {});
    for (auto& p : f.passes) p.gpuMs *= scale;
    addTimes(m, f);
  }
  renderers::FrameResult gbufferOnly = frame({}, {});
  gbufferOnly.passes.pop_back();
  addTimes(m, gbufferOnly);
  json sample = sampleJson(m, {}, 4, 1);
  EXPECT_EQ(sample["frame_ms_frames"], json({0.75, 2.25, 1.5, 0.5}));
  EXPECT_EQ(passOf(sample, "gbuffer")["gpu_ms_frames"], json({0.5, 1.5, 1.0, 0.5}));
  EXPECT_EQ(passOf(sample, "lighting")["gpu_ms_frames"], json({0.25, 0.75, 0.5, 0.0}));
  EXPECT_DOUBLE_EQ(sample["frame_ms"].get<double>(), 1.125);  // median of 0.5, 0.75, 1.5, 2.25
}

}  // namespace
}  // namespace tally::capture

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

// Draws per pass: the kMaxDraws with the most bytes, most first; the others
// summed into draws_rest with the renderer's own rest; materials summed from
// every draw, most first; all per frame (sums over two frames, halved).
TEST(SampleJson, TopDrawsTheRestSummedAndMaterialsPerFrame) {
  const size_t total = kMaxDraws + 4;
  auto drawFrame = [&](uint64_t scale) {
    renderers::FrameResult f = frame({access("diffuse", false, 1, 4)}, {});
    renderers::PassResult& g = f.passes[0];
    for (size_t i = 0; i < total; ++i) {
      renderers::DrawCount d;
      d.index = uint32_t(i);
      d.mesh = std::to_string(i);
      d.material = i % 2 == 0 ? "even" : "odd";
      d.count = scale * (i + 1);
      d.bytesRead = scale * 4 * (i + 1);  // draw i: 4 (i + 1) bytes read, 2 (i + 1) written
      d.bytesWritten = scale * 2 * (i + 1);
      g.draws.push_back(d);
    }
    g.drawsRest = {.index = uint32_t(total), .draws = 7, .count = scale, .bytesRead = scale * 10, .bytesWritten = 0};
    for (const char* material : {"even", "odd"}) {
      renderers::MaterialCount m;
      m.material = material;
      for (const auto& d : g.draws) {
        if (d.material != material) continue;
        ++m.draws;
        m.count += d.count;
        m.bytesRead += d.bytesRead;
        m.bytesWritten += d.bytesWritten;
      }
      g.materials.push_back(m);
    }
    return f;
  };
  SampleMeasure m;
  addCounts(m, drawFrame(1));
  addCounts(m, drawFrame(3));  // per frame: twice frame 1's
  json sample = sampleJson(m, {}, 1, 2);
  const json& gbuffer = passOf(sample, "gbuffer");
  ASSERT_TRUE(gbuffer["draws"].is_array());
  ASSERT_EQ(gbuffer["draws"].size(), kMaxDraws);
  // Most bytes first: the last draw has the most.
  for (size_t k = 0; k < kMaxDraws; ++k) {
    const json& d = gbuffer["draws"][k];
    const size_t i = total - 1 - k;
    EXPECT_EQ(d["index"], i);
    EXPECT_EQ(d["mesh"], std::to_string(i));
    EXPECT_EQ(d["material"], i % 2 == 0 ? "even" : "odd");
    EXPECT_EQ(d["name"], "mesh " + std::to_string(i) + " \u00b7 " + (i % 2 == 0 ? "even" : "odd"));
    EXPECT_DOUBLE_EQ(d["count"].get<double>(), 2.0 * double(i + 1));
    EXPECT_DOUBLE_EQ(d["bytes_read"].get<double>(), 8.0 * double(i + 1));
    EXPECT_DOUBLE_EQ(d["bytes_written"].get<double>(), 4.0 * double(i + 1));
    EXPECT_DOUBLE_EQ(d["bytes"].get<double>(), 12.0 * double(i + 1));
  }
  // The rest: draws 0..3 (1 + 2 + 3 + 4 = 10 units) and the renderer's 7.
  const json& rest = gbuffer["draws_rest"];
  ASSERT_TRUE(rest.is_object());
  EXPECT_EQ(rest["draws"], 4 + 7);
  EXPECT_DOUBLE_EQ(rest["count"].get<double>(), 2.0 * 10 + 2.0);
  EXPECT_DOUBLE_EQ(rest["bytes_read"].get<double>(), 8.0 * 10 + 20.0);
  EXPECT_DOUBLE_EQ(rest["bytes_written"].get<double>(), 4.0 * 10);
  EXPECT_DOUBLE_EQ(rest["bytes"].get<double>(), 12.0 * 10 + 20.0);
  // Materials: odd draws (i + 1 even) sum more than even ones.
  ASSERT_EQ(gbuffer["materials"].size(), 2u);
  EXPECT_EQ(gbuffer["materials"][0]["material"], "odd");
  EXPECT_EQ(gbuffer["materials"][1]["material"], "even");
  double oddUnits = 0, evenUnits = 0;
  for (size_t i = 0; i < total; ++i) (i % 2 == 0 ? evenUnits : oddUnits) += double(i + 1);
  EXPECT_EQ(gbuffer["materials"][0]["draws"], total / 2);
  EXPECT_DOUBLE_EQ(gbuffer["materials"][0]["bytes"].get<double>(), 12.0 * oddUnits);
  EXPECT_DOUBLE_EQ(gbuffer["materials"][1]["bytes_read"].get<double>(), 8.0 * evenUnits);
  // A pass without draws has none of the fields.
  EXPECT_FALSE(passOf(sample, "lighting").contains("draws"));
  EXPECT_FALSE(passOf(sample, "lighting").contains("materials"));
}

// Fewer draws than the cap and no rest from the renderer: no draws_rest.
TEST(SampleJson, NoDrawsRestWithoutARest) {
  renderers::FrameResult f = frame({}, {});
  renderers::DrawCount d;
  d.mesh = "0";
  d.material = "stone";
  d.bytesRead = 16;
  f.passes[0].draws = {d};
  f.passes[0].materials = {{"stone", 1, 0, 16, 0}};
  SampleMeasure m;
  addCounts(m, f);
  json sample = sampleJson(m, {}, 1, 1);
  const json& gbuffer = passOf(sample, "gbuffer");
  EXPECT_EQ(gbuffer["draws"].size(), 1u);
  EXPECT_FALSE(gbuffer.contains("draws_rest"));
  EXPECT_EQ(gbuffer["materials"][0]["bytes"], 16.0);
}

}  // namespace
}  // namespace tally::capture

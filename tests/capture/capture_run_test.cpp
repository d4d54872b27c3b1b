// `tallyd capture` end to end on lavapipe: the result follows
// docs/result-schema.md, bytes follow the formats, screenshots are written,
// and bad specs fail with the field named.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "analysis/image.hpp"
#include "capture/runner.hpp"
#include "gpu/glsl.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/options.hpp"
#include "renderers/renderer.hpp"
#include "scenes/cameras.hpp"
#include "scenes/spec.hpp"
#include "spirv/arith.hpp"
#include "read_file.hpp"
#include "strict.hpp"

namespace tally {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class CaptureRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tally-capture-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  int capture(const json& spec, const std::string& out) {
    std::ofstream(dir_ / "spec.json") << spec.dump();
    std::string cmd = std::string(TALLYD_PATH) + " capture --quiet --spec " + (dir_ / "spec.json").string() +
                      " --out " + out + " 2>" + (dir_ / "err").string();
    return WEXITSTATUS(std::system(cmd.c_str()));
  }

  fs::path dir_;
};

TEST_F(CaptureRun, ResultFollowsTheSchema) {
  json spec = {{"renderers", renderers::rendererNames()},
               {"scenes", {{{"name", "planes"}, {"layers", 3}, {"order", "back-to-front"}}}},
               {"resolutions", {{64, 36}}},
               {"cameras", {{{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}, {"fov_deg", 60}}}},
               {"frames", 3},
               {"counted_frames", 2},
               {"lights", 4}};
  fs::path out = dir_ / "result.json";
  ASSERT_EQ(capture(spec, out.string()), 0) << test::readFile(dir_ / "err");
  json result = json::parse(test::readFile(out));
  ASSERT_TRUE(result.contains("device"));
  EXPECT_TRUE(result["device"].contains("name"));
  ASSERT_TRUE(result.contains("shaders"));
  EXPECT_EQ(result["shaders"]["forward.frag.glsl"].get<std::string>().size(), 16u);
  // The build, and where the capture's time went: every phase it ran, none
  // negative, adding up to the total (wall time measured around them).
  EXPECT_TRUE(result["tally"]["version"].is_string());
  EXPECT_TRUE(result["tally"]["commit"].is_string());
  ASSERT_TRUE(result["timing"].is_object());
  double sum = 0;
  for (const auto& [phase, seconds] : result["timing"].items()) {
    ASSERT_TRUE(seconds.is_number()) << phase;
    EXPECT_GE(seconds.get<double>(), 0.0) << phase;
    if (phase != "total") sum += seconds.get<double>();
  }
  for (const char* phase : {"scene_load", "scene_upload", "reference_images", "setup_shaders", "setup_pipelines",
                            "counted_frames", "counted_readback", "timed_frames", "timed_readback", "image_error",
                            "screenshots", "device", "other"}) {
    EXPECT_TRUE(result["timing"].contains(phase)) << phase;
  }
  EXPECT_GT(result["timing"]["counted_frames"].get<double>(), 0.0);
  EXPECT_NEAR(sum, result["timing"]["total"].get<double>(), 1e-6 + 1e-9 * sum);
  ASSERT_EQ(result["runs"].size(), renderers::rendererNames().size());
  for (const auto& run : result["runs"]) {
    SCOPED_TRACE(run["renderer"].get<std::string>());
    EXPECT_EQ(run["scene"], "planes");
    EXPECT_EQ(run["width"], 64);
    EXPECT_EQ(run["height"], 36);
    std::map<std::string, json> resources;
    for (const auto& r : run["resources"]["list"]) {
      resources[r["name"]] = r;
      if (r["kind"] == "attachment") {
        EXPECT_EQ(r["format_bytes"].get<uint64_t>(), 64u * 36u * r["element_bytes"].get<uint64_t>());
        EXPECT_GE(r["allocation_bytes"].get<uint64_t>(), r["format_bytes"].get<uint64_t>());
      }
    }
    EXPECT_GT(run["resources"]["render_target_bytes"].get<uint64_t>(), 0u);
    ASSERT_EQ(run["samples"].size(), 1u);
    const auto& sample = run["samples"][0];
    for (const char* field : {"camera", "sky_fraction", "screenshot", "frame_ms", "overhead_ratio", "passes"}) {
      EXPECT_TRUE(sample.contains(field)) << field;
    }
    EXPECT_TRUE(fs::exists(dir_ / "result-screenshots" / sample["screenshot"].get<std::string>()));
    EXPECT_GT(sample["frame_ms"].get<double>(), 0.0);
    // The frames' host wall time beside their GPU time: the passes' GPU
    // work lies between submitting and the fence, so the wall median is at
    // least the GPU median, and no frame outlasts its whole phase's clock.
    const json& extras = sample["extras"];
    ASSERT_TRUE(extras.contains("frame_wall_ms") && extras.contains("frame_wall_ms_instrumented")) << extras.dump();
    EXPECT_GE(extras["frame_wall_ms"].get<double>(), sample["frame_ms"].get<double>());
    EXPECT_GE(extras["frame_wall_ms_instrumented"].get<double>(), sample["frame_ms_instrumented"].get<double>());
    EXPECT_LE(extras["frame_wall_ms"].get<double>(), result["timing"]["timed_frames"].get<double>() * 1e3);
    EXPECT_LE(extras["frame_wall_ms_instrumented"].get<double>(), result["timing"]["counted_frames"].get<double>() * 1e3);
    EXPECT_EQ(sample["frames"], 3);
    EXPECT_EQ(sample["counted_frames"], 2);
    EXPECT_EQ(sample["counts_vary"], false);  // a fixed camera counts the same every frame
    if (run["renderer"] != "forward") {
      EXPECT_TRUE(sample.contains("image_error"));
    }
    std::vector<std::string> passNames;
    for (const auto& pass : sample["passes"]) {
      passNames.push_back(pass["name"]);
      for (const char* field : {"name", "gpu_ms", "fragment_invocations", "resources"}) {
        EXPECT_TRUE(pass.contains(field)) << field;
      }
      for (const auto& r : pass["resources"]) {
        for (const char* field : {"name", "format", "kind", "access", "count", "bytes"}) {
          EXPECT_TRUE(r.contains(field)) << field;
        }
        EXPECT_TRUE(r["access"] == "read" || r["access"] == "write");
        // Bytes follow the format the renderer created (images) ...
        auto info = resources.find(r["name"].get<std::string>());
        if (info != resources.end() && info->second["kind"] != "buffer" && r["source"] == "counter") {
          double perElement = info->second["element_bytes"].get<double>();
          double count = r["count"].get<double>(), bytes = r["bytes"].get<double>();
          if (info->second["kind"] == "depth" && r["access"] == "read") {
            // Sampling the depth aspect of D32_S8 reads its 4 depth bytes.
            EXPECT_DOUBLE_EQ(bytes, count * 4) << r.dump();
          } else {
            EXPECT_DOUBLE_EQ(bytes, count * perElement) << r.dump();
          }
        }
      }
    }
    auto expected = (*renderers::makeRenderer(run["renderer"].get<std::string>()))->passNames();
    EXPECT_EQ(passNames, expected);
  }
}

// Per-frame times: the sample's frame_ms_frames and every pass's
// gpu_ms_frames hold one entry per uninstrumented frame, in order, and their
// medians are the frame_ms and gpu_ms the result reports.
double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  size_t n = values.size();
  return n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

TEST_F(CaptureRun, PerFrameTimesHaveFramesEntriesWhoseMediansAreTheTimes) {
  json spec = {{"renderers", {"forward", "deferred"}},
               {"scenes", {{{"name", "planes"}, {"layers", 2}}}},
               {"resolutions", {{32, 18}}},
               {"cameras", {{{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}, {"fov_deg", 60}}}},
               {"frames", 5},
               {"counted_frames", 1},
               {"lights", 2},
               {"ceilings", false}};
  fs::path out = dir_ / "result.json";
  ASSERT_EQ(capture(spec, out.string()), 0) << test::readFile(dir_ / "err");
  json result = json::parse(test::readFile(out));
  ASSERT_EQ(result["runs"].size(), 2u);
  for (const auto& run : result["runs"]) {
    SCOPED_TRACE(run["renderer"].get<std::string>());
    for (const auto& sample : run["samples"]) {
      ASSERT_TRUE(sample["frame_ms_frames"].is_array());
      auto frames = sample["frame_ms_frames"].get<std::vector<double>>();
      ASSERT_EQ(frames.size(), 5u);
      ASSERT_EQ(sample["frames"], 5);
      for (double ms : frames) EXPECT_GE(ms, 0.0);
      EXPECT_DOUBLE_EQ(median(frames), sample["frame_ms"].get<double>());
      ASSERT_FALSE(sample["passes"].empty());
      std::vector<double> sums(5, 0.0);
      for (const auto& pass : sample["passes"]) {
        SCOPED_TRACE(pass["name"].get<std::string>());
        ASSERT_TRUE(pass["gpu_ms_frames"].is_array());
        auto passFrames = pass["gpu_ms_frames"].get<std::vector<double>>();
        ASSERT_EQ(passFrames.size(), 5u);
        EXPECT_DOUBLE_EQ(median(passFrames), pass["gpu_ms"].get<double>());
        for (size_t f = 0; f < 5; ++f) sums[f] += passFrames[f];
      }
      // A frame's time is its passes' times (the same frames, in the same order).
      for (size_t f = 0; f < 5; ++f) EXPECT_NEAR(sums[f], frames[f], 1e-9 * (1 + frames[f])) << "frame " << f;
    }
  }
}

// Variants: each run carries its canonical options and label; a run without
// options is as before (no variant_error); the variant that is its own
// reference (barycentrics=float32) has none; one that is not
// (uv_derivatives=unorm16-clamped, reference: float32) carries the error of
// its image against the reference variant's, equal to compareImages of the
// two images rendered here.
TEST_F(CaptureRun, VariantsCarryOptionsAndTheirImageError) {
  const json scene = {{"name", "planes"}, {"layers", 3}, {"order", "back-to-front"}};
  const json camera = {{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}, {"fov_deg", 60}};
  json spec = {{"renderers",
                {"visbuffer",
                 {{"renderer", "visbuffer"}, {"options", {{"barycentrics", "float32"}}}},
                 {{"renderer", "visbuffer"}, {"options", {{"uv_derivatives", "unorm16-clamped"}, {"barycentrics", "unorm16"}}}}}},
               {"scenes", {scene}},
               {"resolutions", {{64, 36}}},
               {"cameras", {camera}},
               {"frames", 1},
               {"lights", 4}};
  fs::path out = dir_ / "result.json";
  ASSERT_EQ(capture(spec, out.string()), 0) << test::readFile(dir_ / "err");
  json result = json::parse(test::readFile(out));
  ASSERT_EQ(result["runs"].size(), 3u);
  const json& plain = result["runs"][0];
  const json& own = result["runs"][1];
  const json& clamped = result["runs"][2];
  EXPECT_EQ(plain["options"], json::object());
  EXPECT_EQ(plain["variant"], "visbuffer");
  EXPECT_EQ(own["options"], json({{"barycentrics", "float32"}}));
  EXPECT_EQ(own["variant"], "visbuffer barycentrics=float32");
  // The default written out is dropped.
  EXPECT_EQ(clamped["options"], json({{"uv_derivatives", "unorm16-clamped"}}));
  EXPECT_EQ(clamped["variant"], "visbuffer uv_derivatives=unorm16-clamped");
  for (const json* run : {&plain, &own, &clamped}) {
    ASSERT_EQ((*run)["samples"].size(), 1u);
    EXPECT_TRUE((*run)["samples"][0]["extras"].is_object());
    EXPECT_TRUE((*run)["samples"][0].contains("image_error"));
  }
  EXPECT_FALSE(plain["samples"][0].contains("variant_error"));
  EXPECT_FALSE(own["samples"][0].contains("variant_error"));
  ASSERT_TRUE(clamped["samples"][0].contains("variant_error"));
  const json& error = clamped["samples"][0]["variant_error"];
  EXPECT_EQ(error["against"], "visbuffer uv_derivatives=float32");

  // The two images, rendered here uninstrumented as the capture does.
  std::vector<std::vector<uint8_t>> images;
  auto done = gpu::withDevice("", [&](gpu::Context& ctx) -> Result<json> {
    auto made = scenes::makeScene(scene);
    if (!made) return makeError(made.error());
    auto cameras = scenes::camerasFromJson(json::array({camera}));
    if (!cameras) return makeError(cameras.error());
    renderers::GpuScene gpuScene;
    auto uploaded = gpuScene.upload(ctx, *made);
    if (!uploaded) return makeError(uploaded.error());
    for (const json& options : {json({{"uv_derivatives", "float32"}}), json({{"uv_derivatives", "unorm16-clamped"}})}) {
      auto renderer = renderers::makeRenderer("visbuffer");
      if (!renderer) return makeError(renderer.error());
      renderers::RendererOptions ro{{64, 36}, false, spirv::Mode{}, 4};
      renderers::applyOptions(options, ro);
      auto ok = (*renderer)->setup(ctx, gpuScene, ro);
      if (!ok) return makeError(ok.error());
      (*renderer)->renderFrame((*cameras)[0]);
      images.push_back((*renderer)->finalImage());
      (*renderer)->destroy();
    }
    gpuScene.destroy();
    return json::object();
  });
  ASSERT_TRUE(done) << done.error();
  ASSERT_EQ(images.size(), 2u);
  auto expected = analysis::compareImages(images[1], images[0], 64, 36);
  ASSERT_TRUE(expected) << expected.error();
  EXPECT_EQ(error["identical"].get<bool>(), std::isinf(expected->psnr));
  if (std::isinf(expected->psnr)) {
    EXPECT_TRUE(error["psnr"].is_null());
  } else {
    EXPECT_DOUBLE_EQ(error["psnr"].get<double>(), expected->psnr);
  }
  EXPECT_EQ(error["max_abs"].get<int>(), expected->maxAbs);
  EXPECT_DOUBLE_EQ(error["mean_abs"].get<double>(), expected->meanAbs);
}

// The static arithmetic of one shader file from shaders/ (no defines), per invocation.
uint64_t staticOps(const std::string& file) {
  auto dir = renderers::shaderDirectory();
  EXPECT_TRUE(dir.ok());
  std::ifstream in(*dir + "/" + file);
  std::stringstream text;
  text << in.rdbuf();
  glsl::CompileOptions options;
  options.fileName = file;
  options.includeDirs = {*dir};
  auto stage = glsl::stageFromFileName(file);
  auto words = glsl::compile(text.str(), *stage, options);
  EXPECT_TRUE(words.ok()) << (words.ok() ? "" : words.error());
  auto counted = spirv::countArithmetic(*words);
  EXPECT_TRUE(counted.ok() && counted->size() == 1);
  return (*counted)[0].ops.total();
}

// The roofline (docs/result-schema.md): the device's ceilings, and per pass
// its arithmetic estimate (the shaders' static counts x their counted
// invocations) against its bytes and uninstrumented time.
TEST_F(CaptureRun, RooflinePerPass) {
  json spec = {{"renderers", {"deferred"}},
               {"scenes", {{{"name", "planes"}, {"layers", 2}, {"order", "back-to-front"}}}},
               {"resolutions", {{64, 36}}},
               {"cameras", {{{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}, {"fov_deg", 60}}}},
               {"frames", 2},
               {"counted_frames", 1},
               {"lights", 4}};
  fs::path out = dir_ / "roofline.json";
  ASSERT_EQ(capture(spec, out.string()), 0) << test::readFile(dir_ / "err");
  json result = json::parse(test::readFile(out));
  const json& c = result["device"]["ceilings"];
  ASSERT_TRUE(c.is_object()) << result["device"].dump();
  const double peakBandwidth = c["bandwidth_bytes_per_s"].get<double>();
  const double peakOps = c["arithmetic_ops_per_s"].get<double>();
  EXPECT_GT(peakBandwidth, 0.0);
  EXPECT_GT(peakOps, 0.0);
  EXPECT_GE(c["copy_bytes"].get<uint64_t>(), 1u << 20);
  EXPECT_TRUE(result["timing"].contains("ceilings"));

  const json& sample = result["runs"][0]["samples"][0];
  std::map<std::string, const json*> byName;
  for (const auto& pass : sample["passes"]) {
    byName[pass["name"].get<std::string>()] = &pass;
    const json& r = pass["roofline"];
    ASSERT_TRUE(r.is_object()) << pass["name"];
    ASSERT_TRUE(r["arithmetic_ops"].is_number()) << pass["name"];
    const double ops = r["arithmetic_ops"].get<double>(), bytes = pass["bytes"].get<double>();
    const double seconds = pass["gpu_ms"].get<double>() * 1e-3;
    EXPECT_DOUBLE_EQ(r["bytes_requested"].get<double>(), bytes);
    // No footprint is measured here: its figures stay null.
    EXPECT_TRUE(r["footprint_bytes"].is_null());
    EXPECT_TRUE(r["intensity_footprint"].is_null());
    EXPECT_TRUE(r["bandwidth_footprint"].is_null());
    if (bytes > 0) {
      EXPECT_DOUBLE_EQ(r["intensity_requested"].get<double>(), ops / bytes) << pass["name"];
    }
    if (seconds > 0 && bytes > 0) {
      EXPECT_DOUBLE_EQ(r["bandwidth_requested"].get<double>(), bytes / seconds);
      EXPECT_DOUBLE_EQ(r["fraction_of_peak_bandwidth"].get<double>(), bytes / seconds / peakBandwidth);
      EXPECT_DOUBLE_EQ(r["ops_per_s"].get<double>(), ops / seconds);
      EXPECT_DOUBLE_EQ(r["fraction_of_peak_arithmetic"].get<double>(), ops / seconds / peakOps);
      const double intensity = ops / bytes;
      EXPECT_EQ(r["bound"], intensity < peakOps / peakBandwidth ? "memory" : "compute");
    }
  }
  // tonemap: fullscreen.vert on the triangle's 3 vertices, tonemap.frag on
  // every pixel (its counted fragment invocations).
  ASSERT_TRUE(byName.count("tonemap"));
  const json& tonemap = *byName["tonemap"];
  EXPECT_EQ(tonemap["fragment_invocations"].get<double>(), 64.0 * 36.0);
  const double expected = double(staticOps("tonemap.frag.glsl")) * 64 * 36 + double(staticOps("fullscreen.vert.glsl")) * 3;
  EXPECT_GT(expected, 64.0 * 36.0);
  EXPECT_DOUBLE_EQ(tonemap["roofline"]["arithmetic_ops"].get<double>(), expected);

  // "ceilings": false skips them: no ceilings, arithmetic still estimated,
  // fractions of peak null.
  spec["ceilings"] = false;
  ASSERT_EQ(capture(spec, out.string()), 0) << test::readFile(dir_ / "err");
  result = json::parse(test::readFile(out));
  EXPECT_FALSE(result["device"].contains("ceilings"));
  EXPECT_FALSE(result["timing"].contains("ceilings"));
  for (const auto& pass : result["runs"][0]["samples"][0]["passes"]) {
    EXPECT_TRUE(pass["roofline"]["arithmetic_ops"].is_number());
    EXPECT_TRUE(pass["roofline"]["fraction_of_peak_bandwidth"].is_null());
    EXPECT_TRUE(pass["roofline"]["bound"].is_null());
  }
}

// A pass's "draws" (with "draws_rest") sum to its counted lines and its
// "materials" to its draws; on a shading pass without draws, "materials"
// splits the material-map reads. Returns whether the pass had draws.
bool checkDrawsAndMaterials(const json& pass) {
  double lineRead = 0, lineWritten = 0, mapRead = 0;
  for (const json& line : pass["resources"]) {
    if (line["source"] != "counter") continue;
    const double bytes = line["bytes"].get<double>();
    (line["access"] == "write" ? lineWritten : lineRead) += bytes;
    if (line["access"] == "read" && line["name"].get<std::string>().rfind("material_maps.", 0) == 0) mapRead += bytes;
  }
  double drawRead = 0, drawWritten = 0, materialRead = 0, materialWritten = 0;
  for (const json& d : pass.value("draws", json::array())) {
    drawRead += d["bytes_read"].get<double>();
    drawWritten += d["bytes_written"].get<double>();
    EXPECT_EQ(d["bytes"].get<double>(), d["bytes_read"].get<double>() + d["bytes_written"].get<double>());
  }
  if (pass.contains("draws_rest")) {
    drawRead += pass["draws_rest"]["bytes_read"].get<double>();
    drawWritten += pass["draws_rest"]["bytes_written"].get<double>();
  }
  for (const json& m : pass.value("materials", json::array())) {
    materialRead += m["bytes_read"].get<double>();
    materialWritten += m["bytes_written"].get<double>();
  }
  if (pass.value("draws", json::array()).empty()) {
    if (pass.contains("materials")) {
      EXPECT_EQ(materialRead, mapRead);
    }
    return false;
  }
  EXPECT_EQ(drawRead, lineRead);
  EXPECT_EQ(drawWritten, lineWritten);
  EXPECT_EQ(materialRead, drawRead);
  EXPECT_EQ(materialWritten, drawWritten);
  return true;
}

// Per-site counts ("sites": true) in every renderer, counting mode and with
// footprint on: each counted line is the sum of its sites' counts and bytes;
// every line, footprint included, equals the same capture's without sites
// (a second mechanism: slots shared per resource); and every site of the
// built-in shaders maps to a line of a shader file the run carries.
TEST_F(CaptureRun, SitesSumToTheirLinesAndChangeNoLine) {
  json spec = {{"renderers", renderers::rendererNames()},
               {"scenes", {{{"name", "planes"}, {"layers", 2}}}},
               {"resolutions", {{40, 24}}},
               {"cameras", {{{"eye", {0, 0, 0}}, {"target", {0, 0, -1}}, {"fov_deg", 60}}}},
               {"frames", 1},
               {"counted_frames", 1},
               {"lights", 3},
               {"counting", {"exact", "accumulate", "accumulate:lane"}},
               {"footprint", 64},
               {"ceilings", false}};
  fs::path plainOut = dir_ / "plain.json", sitesOut = dir_ / "sites.json";
  ASSERT_EQ(capture(spec, plainOut.string()), 0) << test::readFile(dir_ / "err");
  spec["sites"] = true;
  ASSERT_EQ(capture(spec, sitesOut.string()), 0) << test::readFile(dir_ / "err");
  json plain = json::parse(test::readFile(plainOut)), sites = json::parse(test::readFile(sitesOut));
  ASSERT_EQ(plain["runs"].size(), sites["runs"].size());
  size_t counted = 0, drawPasses = 0;
  for (size_t r = 0; r < sites["runs"].size(); ++r) {
    const json& run = sites["runs"][r];
    SCOPED_TRACE(run["renderer"].get<std::string>() + " " + run["counting"].get<std::string>());
    ASSERT_TRUE(run["shader_sources"].is_object());
    for (size_t p = 0; p < run["samples"][0]["passes"].size(); ++p) {
      const json& pass = run["samples"][0]["passes"][p];
      const json& before = plain["runs"][r]["samples"][0]["passes"][p];
      SCOPED_TRACE(pass["name"].get<std::string>());
      EXPECT_EQ(pass["resources"], before["resources"]);
      drawPasses += checkDrawsAndMaterials(pass) ? 1 : 0;  // "sites" counts per draw too
      std::map<std::string, std::pair<double, double>> bySites;
      for (const json& site : pass.value("sites", json::array())) {
        bySites[site["resource"].get<std::string>() + "/" + site["access"].get<std::string>()].first += site["count"].get<double>();
        bySites[site["resource"].get<std::string>() + "/" + site["access"].get<std::string>()].second += site["bytes"].get<double>();
        ASSERT_TRUE(site["line"].is_number()) << site.dump();
        const std::string file = site["file"].get<std::string>();
        ASSERT_TRUE(run["shader_sources"].contains(file)) << file;
        const std::string text = run["shader_sources"][file].get<std::string>();
        EXPECT_LE(site["line"].get<size_t>(), size_t(std::count(text.begin(), text.end(), '\n')) + 1) << site.dump();
        EXPECT_FALSE(site["disassembly"].get<std::string>().empty());
      }
      for (const json& line : pass["resources"]) {
        if (line["source"] != "counter") continue;
        const auto& [count, bytes] = bySites[line["name"].get<std::string>() + "/" + line["access"].get<std::string>()];
        EXPECT_EQ(count, line["count"].get<double>()) << line.dump();
        EXPECT_EQ(bytes, line["bytes"].get<double>()) << line.dump();
        ++counted;
      }
    }
  }
  EXPECT_GT(counted, 0u);
  EXPECT_GT(drawPasses, 0u);
}

// Every site of every built-in pass maps to a line of a shader file, on a
// real model whose materials take the texture-transform path: each map read
// sits in the merge block of a `?:` (the map's uv set), a block glslang gives
// no line of its own.
TEST_F(CaptureRun, EverySiteOfAKhronosModelHasItsSourceLine) {
  const fs::path model = fs::path(TALLY_KHRONOS_DIR) / "ToyCar/glTF/ToyCar.gltf";
  if (!fs::exists(model)) TALLY_SKIP_UNLESS_STRICT("no " << model);
  json spec = {{"renderers", renderers::rendererNames()},
               {"scenes", {{{"gltf", model.string()}}}},
               {"resolutions", {{48, 32}}},
               {"frames", 1},
               {"counted_frames", 1},
               {"sites", true},
               {"ceilings", false}};
  fs::path out = dir_ / "toycar.json";
  ASSERT_EQ(capture(spec, out.string()), 0) << test::readFile(dir_ / "err");
  json result = json::parse(test::readFile(out));
  size_t sites = 0;
  for (const json& run : result["runs"]) {
    for (const json& pass : run["samples"][0]["passes"]) {
      for (const json& site : pass.value("sites", json::array())) {
        ++sites;
        ASSERT_TRUE(site["line"].is_number()) << run["renderer"] << " " << pass["name"] << ": " << site.dump();
        EXPECT_TRUE(run["shader_sources"].contains(site["file"].get<std::string>())) << site.dump();
      }
    }
  }
  EXPECT_GT(sites, 100u) << "ToyCar's passes have about 200 sites over the renderers";
}

TEST_F(CaptureRun, BadSpecNamesTheFieldAndWritesNothing) {
  json spec = {{"renderers", {"forward", "warp"}}, {"resolutions", {{64, 36}}}};
  fs::path out = dir_ / "bad.json";
  EXPECT_EQ(capture(spec, out.string()), 1);
  std::string err = test::readFile(dir_ / "err");
  EXPECT_NE(err.find("renderers[1]: unknown renderer 'warp'"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace tally

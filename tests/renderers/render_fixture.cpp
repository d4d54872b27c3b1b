#include "render_fixture.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>

#include <gtest/gtest.h>

#include "scenes/cameras.hpp"
#include "scenes/spec.hpp"

namespace tally::renderers::fixture {
namespace {

// The process-wide device and the uploaded scenes (a spec's text as the key),
// torn down in order by the environment below.
struct Shared {
  std::unique_ptr<gpu::Context> ctx;
  std::string error;
  bool tried = false;
  std::map<std::string, std::unique_ptr<TestScene>> scenes;
};

Shared& shared() {
  static Shared s;
  return s;
}

class DeviceEnvironment : public ::testing::Environment {
 public:
  void TearDown() override {
    Shared& s = shared();
    s.scenes.clear();  // GpuScene::destroy needs the device
    if (s.ctx) gpu::destroyContext(*s.ctx);
    s.ctx.reset();
  }
};
[[maybe_unused]] const auto* const kEnvironment = ::testing::AddGlobalTestEnvironment(new DeviceEnvironment);

// The frame as text, for the test log (TALLY_TEST_VERBOSE=1).
void printFrame(const std::string& title, const Rendered& r) {
  if (std::getenv("TALLY_TEST_VERBOSE") == nullptr) return;
  std::printf("== %s %s\n", title.c_str(), r.notes.dump().c_str());
  for (const auto& p : r.frame.passes) {
    std::printf("  %-10s %.3f ms, fragments counted %llu, statistic %lld\n", p.name.c_str(), p.gpuMs,
                (unsigned long long)p.fragmentInvocations, (long long)p.fragmentInvocationsStatistic);
    for (const auto& a : p.accesses) {
      std::printf("    %-5s %-24s %12llu  %12llu B  %s\n", a.write ? "write" : "read", a.resource.c_str(),
                  (unsigned long long)a.count, (unsigned long long)a.bytes, a.source.c_str());
    }
  }
}

void dumpImage(const std::string& name, const nlohmann::json& spec, VkExtent2D extent, const Rendered& r) {
  const char* dir = std::getenv("TALLY_TEST_DUMP");  // raw RGBA8 images for a look
  if (dir == nullptr) return;
  std::string label = spec.dump().substr(0, 48);
  for (auto& ch : label) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  std::string file = std::string(dir) + "/" + name + "_" + label + "_" + std::to_string(extent.width) + "x" +
                     std::to_string(extent.height) + ".rgba";
  if (FILE* f = std::fopen(file.c_str(), "wb")) {
    std::fwrite(r.image.data(), 1, r.image.size(), f);
    std::fclose(f);
  }
}

}  // namespace

gpu::Context* context() {
  Shared& s = shared();
  if (!s.tried) {
    s.tried = true;
    gpu::ContextOptions options;
    if (const char* device = std::getenv("TALLY_TEST_DEVICE")) options.device = device;
    // TALLY_TEST_VALIDATION=1: VK_LAYER_KHRONOS_validation where installed (messages on stderr).
    if (std::getenv("TALLY_TEST_VALIDATION") != nullptr) options.validation = true;
    auto created = gpu::createContext(options);
    if (created) {
      s.ctx = std::make_unique<gpu::Context>(std::move(created).value());
    } else {
      s.error = created.error();
    }
  }
  if (!s.ctx) ADD_FAILURE() << "no Vulkan device: " << s.error;
  return s.ctx.get();
}

TestScene& testScene(const nlohmann::json& spec) {
  auto& entry = shared().scenes[spec.dump()];
  if (!entry) {
    entry = std::make_unique<TestScene>();
    auto scene = scenes::makeScene(spec);
    EXPECT_TRUE(scene.ok()) << (scene ? "" : scene.error());
    entry->scene = std::move(scene).value();
    entry->gpu = std::make_unique<GpuScene>();
    auto uploaded = entry->gpu->upload(*context(), entry->scene);
    EXPECT_TRUE(uploaded.ok()) << (uploaded ? "" : uploaded.error());
    if (!entry->scene.fixedCameras.empty()) {
      entry->camera = entry->scene.fixedCameras[0];
    } else {
      // The automatic camera closest to a third sky: geometry, sky and edges.
      auto cameras = scenes::autoCameras(entry->scene);
      EXPECT_FALSE(cameras.empty());
      float best = 2;
      for (const auto& c : cameras) {
        if (std::abs(c.skyFraction - 0.3f) < best) {
          best = std::abs(c.skyFraction - 0.3f);
          entry->camera = c;
        }
      }
    }
  }
  return *entry;
}

Rendered render(const std::string& name, const nlohmann::json& spec, VkExtent2D extent,
                const std::function<void(RendererOptions&)>& adjust, int frames, bool expectFailure) {
  Rendered out;
  gpu::Context* ctx = context();
  if (ctx == nullptr) return out;
  TestScene& s = testScene(spec);
  auto renderer = makeRenderer(name);
  EXPECT_TRUE(renderer.ok()) << (renderer ? "" : renderer.error());
  if (!renderer) return out;
  RendererOptions options;
  options.extent = extent;
  options.lights = kTestLights;
  if (adjust) adjust(options);
  auto ok = (*renderer)->setup(*ctx, *s.gpu, options);
  if (!ok) {
    out.error = ok.error();
    EXPECT_TRUE(expectFailure) << name << ": " << out.error;
    return out;
  }
  EXPECT_FALSE(expectFailure) << name << " set up a scene it should refuse: " << spec.dump();
  for (int f = 0; f < frames; ++f) out.frame = (*renderer)->renderFrame(s.camera);
  out.image = (*renderer)->finalImage();
  out.notes = (*renderer)->notes();
  out.extras = (*renderer)->frameExtras();
  out.resources = (*renderer)->resources();
  out.ok = true;
  EXPECT_EQ(out.frame.passes.size(), (*renderer)->passNames().size());
  for (size_t i = 0; i < out.frame.passes.size(); ++i) {
    EXPECT_EQ(out.frame.passes[i].name, (*renderer)->passNames()[i]);
  }
  EXPECT_EQ(out.image.size(), size_t(extent.width) * extent.height * 4);
  (*renderer)->destroy();
  dumpImage(name, spec, extent, out);
  printFrame(
      name + " " + spec.dump() + " " + std::to_string(extent.width) + "x" + std::to_string(extent.height),
      out);
  return out;
}

const PassResult& passNamed(const Rendered& r, const std::string& name) {
  for (const auto& p : r.frame.passes) {
    if (p.name == name) return p;
  }
  static PassResult none;
  ADD_FAILURE() << "no pass " << name;
  return none;
}

uint64_t counted(const PassResult& p, const std::string& prefix, bool write, const std::string& source) {
  uint64_t n = 0;
  for (const auto& a : p.accesses) {
    if (a.write == write && a.source == source && a.resource.rfind(prefix, 0) == 0) n += a.count;
  }
  return n;
}

uint64_t bytes(const PassResult& p, const std::string& name, bool write, const std::string& source) {
  uint64_t n = 0;
  for (const auto& a : p.accesses) {
    if (a.write == write && a.source == source && a.resource == name) n += a.bytes;
  }
  return n;
}

nlohmann::json planes(int layers, const char* order, double coverage) {
  return {{"name", "planes"}, {"layers", layers}, {"order", order}, {"coverage", coverage}};
}

nlohmann::json sky(double coverage) { return {{"name", "sky"}, {"coverage", coverage}}; }

}  // namespace tally::renderers::fixture

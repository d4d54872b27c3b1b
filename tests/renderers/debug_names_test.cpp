// Renderers as plain applications (tallyd play): every resource's images and
// buffers carry its name through VK_EXT_debug_utils, every pass is one label
// in order, and uninstrumented pipeline layouts hold no counter set. The
// names are checked through Context::debugUtilsHook, which sees every call
// whether or not the driver has the extension.
#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gpu/debug_names.hpp"
#include "gpu/shaders.hpp"
#include "renderers/options.hpp"
#include "render_fixture.hpp"
#include "shared.h"

namespace tally::renderers {
using namespace fixture;
namespace {

struct Variant {
  std::string renderer;
  nlohmann::json options = nlohmann::json::object();
};

// Every renderer and workload as it is, and the variants that change what is
// bound or how passes are recorded: subpasses, compute shading, shadows,
// bloom, LOD, packed vertices, MSAA, the overdraw view.
std::vector<Variant> variants() {
  std::vector<Variant> out;
  for (const auto& name : rendererNames()) out.push_back({name});
  for (const auto& name : workloadNames()) out.push_back({name});
  out.push_back({"deferred", {{"gbuffer", "subpass"}}});
  out.push_back({"deferred", {{"shading", "compute"}, {"shadows", "hard"}}});
  out.push_back({"visbuffer", {{"msaa", 4}, {"bloom", "separable"}}});
  out.push_back({"visbuffer-lean", {{"lod", 2}, {"tangent_frame", "quaternion"}}});
  out.push_back({"forward", {{"output", "overdraw"}, {"zprepass", true}}});
  return out;
}

std::string label(const Variant& v) { return v.renderer + " " + v.options.dump(); }

// What the hook saw, in order.
struct Recorder {
  std::vector<gpu::DebugUtilsEvent> events;
  explicit Recorder(gpu::Context& ctx) : ctx_(ctx) {
    ctx_.debugUtilsHook = [this](const gpu::DebugUtilsEvent& e) { events.push_back(e); };
  }
  ~Recorder() { ctx_.debugUtilsHook = nullptr; }
  // handle -> the last name set on it
  std::map<std::pair<VkObjectType, uint64_t>, std::string> names() const {
    std::map<std::pair<VkObjectType, uint64_t>, std::string> out;
    for (const auto& e : events) {
      if (e.kind == gpu::DebugUtilsEvent::Kind::ObjectName) out[{e.objectType, e.handle}] = e.name;
    }
    return out;
  }

 private:
  gpu::Context& ctx_;
};

std::unique_ptr<Renderer> setUp(gpu::Context& ctx, const Variant& v, const nlohmann::json& scene, bool instrumented) {
  auto made = makeRenderer(v.renderer);
  EXPECT_TRUE(made.ok());
  if (!made) return nullptr;
  RendererOptions options;
  options.extent = {64, 36};
  options.lights = kTestLights;
  options.instrumented = instrumented;
  auto canonical = canonicalOptions(v.renderer, v.options);
  EXPECT_TRUE(canonical.ok()) << (canonical ? "" : canonical.error());
  if (!canonical) return nullptr;
  applyOptions(*canonical, options);
  auto ok = (*made)->setup(ctx, *testScene(scene).gpu, options);
  EXPECT_TRUE(ok.ok()) << label(v) << ": " << (ok ? "" : ok.error());
  if (!ok) return nullptr;
  return std::move(made).value();
}

// Every image and buffer a renderer lists is named after its resource, and
// every line an instrumented frame counts is such a name: a layer that
// attributes its counts by object name finds the same lines.
TEST(RendererDebugNames, EveryResourceObjectIsNamedAfterItsLine) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  for (const nlohmann::json& scene : {planes(3, "back-to-front"), nlohmann::json("atrium")}) {
    testScene(scene);  // uploaded before recording
    for (const auto& v : variants()) {
      for (bool instrumented : {false, true}) {
        SCOPED_TRACE(label(v) + " on " + scene.dump() + (instrumented ? " instrumented" : " plain"));
        Recorder recorder(*ctx);
        auto r = setUp(*ctx, v, scene, instrumented);
        if (!r) continue;
        const auto names = recorder.names();
        EXPECT_FALSE(names.empty());
        std::set<std::string> named;
        for (const auto& res : r->resources()) {
          EXPECT_FALSE(res.objects.empty()) << res.name << " has no image or buffer to name";
          for (const auto& o : res.objects) {
            auto it = names.find({o.type, o.handle});
            ASSERT_NE(it, names.end()) << res.name << ": an object was not named";
            EXPECT_EQ(it->second, res.name);
          }
          named.insert(res.name);
        }
        if (instrumented) {
          const FrameResult frame = r->renderFrame(testScene(scene).camera);
          size_t lines = 0;
          for (const auto& p : frame.passes) lines += p.accesses.size();
          EXPECT_GT(lines, 0u);
          for (const auto& p : frame.passes) {
            for (const auto& a : p.accesses) {
              EXPECT_TRUE(named.count(a.resource)) << p.name << ": line " << a.resource << " (" << a.source
                                                   << ") names no object";
            }
          }
        }
        r->destroy();
      }
    }
  }
}

// A frame is one label per pass, in the passes' order, each closed before the
// next opens, in the one command buffer the frame submits.
TEST(RendererDebugNames, PassLabelsAreBalancedAndInPassOrder) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  const nlohmann::json scene = planes(3, "back-to-front");
  testScene(scene);
  for (const auto& v : variants()) {
    for (bool instrumented : {false, true}) {
      SCOPED_TRACE(label(v) + (instrumented ? " instrumented" : " plain"));
      auto r = setUp(*ctx, v, scene, instrumented);
      if (!r) continue;
      for (int frame = 0; frame < 2; ++frame) {
        Recorder recorder(*ctx);
        const FrameResult result = r->renderFrame(testScene(scene).camera);
        std::vector<std::string> labels;
        std::set<VkCommandBuffer> buffers;
        bool open = false;
        for (const auto& e : recorder.events) {
          ASSERT_NE(e.kind, gpu::DebugUtilsEvent::Kind::ObjectName) << "a name set while rendering: " << e.name;
          buffers.insert(e.commandBuffer);
          if (e.kind == gpu::DebugUtilsEvent::Kind::BeginLabel) {
            EXPECT_FALSE(open) << "label " << e.name << " opened inside another";
            labels.push_back(e.name);
            open = true;
          } else {
            EXPECT_TRUE(open) << "a label closed that was not open";
            open = false;
          }
        }
        EXPECT_FALSE(open) << "the last label was not closed";
        EXPECT_EQ(buffers.size(), 1u);
        EXPECT_EQ(labels, r->passNames());
        std::vector<std::string> reported;
        for (const auto& p : result.passes) reported.push_back(p.name);
        EXPECT_EQ(labels, reported);
      }
      r->destroy();
    }
  }
}

// Uninstrumented pipeline layouts end at the last set the shaders use (the
// pass inputs at most) and no counter set is bound; instrumented ones keep
// the counter set where they always had it.
TEST(RendererDebugNames, PlainPipelineLayoutsHoldNoCounterSet) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  const nlohmann::json scene = planes(3, "back-to-front");
  const uint32_t counterSet = gpu::instrumentOptionsFor(*ctx, spirv::Mode{spirv::CountMode::Accumulate}).set;
  for (const auto& v : variants()) {
    for (bool instrumented : {false, true}) {
      SCOPED_TRACE(label(v) + (instrumented ? " instrumented" : " plain"));
      auto r = setUp(*ctx, v, scene, instrumented);
      if (!r) continue;
      if (instrumented) {
        EXPECT_EQ(r->maxPipelineSetCount(), counterSet + 1);
      } else {
        EXPECT_GE(r->maxPipelineSetCount(), shaders::kSetGeometry + 1);
        EXPECT_LE(r->maxPipelineSetCount(), shaders::kSetPassInput + 1);
      }
      const FrameResult frame = r->renderFrame(testScene(scene).camera);
      EXPECT_EQ(frame.passes.size(), r->passNames().size());
      if (!instrumented) {
        for (const auto& p : frame.passes) EXPECT_TRUE(p.accesses.empty()) << p.name;
      }
      r->destroy();
    }
  }
}

}  // namespace
}  // namespace tally::renderers

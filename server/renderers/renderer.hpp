// The renderer interface: what the capture engine drives. Each renderer is one
// file, declares its passes and resources (with their real formats and
// allocation sizes), renders frames and reports per-pass, per-resource counts.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <vulkan/vulkan.h>
#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "gpu/context.hpp"
#include "scenes/scene.hpp"
#include "spirv/instrument.hpp"

namespace tally::renderers {

class GpuScene;

enum class ResourceKind { Texture, Attachment, Depth, Buffer };
std::string_view toString(ResourceKind kind);  // "texture", "attachment", "depth", "buffer"

// A resource a renderer created. Bytes come from these formats, never from a
// hard-coded multiplier.
struct ResourceInfo {
  std::string name;          // e.g. "gbuffer.normal", "vertices", "material_maps"
  ResourceKind kind = ResourceKind::Texture;
  VkFormat format = VK_FORMAT_UNDEFINED;  // VK_FORMAT_UNDEFINED for buffers
  std::string formatName;    // "R16G16B16A16_SFLOAT"; "" for buffers
  uint32_t elementBytes = 0;  // bytes per texel (format) or per buffer element
  uint32_t width = 0, height = 0;  // images; 0 for buffers
  uint64_t allocationBytes = 0;    // VkMemoryRequirements::size of the real allocation(s)
  std::string usage;               // e.g. "color_attachment|sampled"
};

// One line of a pass's traffic: a resource read or written.
struct Access {
  std::string resource;  // ResourceInfo::name
  bool write = false;
  uint64_t count = 0;    // events (counter totals, or derived: see source)
  uint64_t bytes = 0;    // count x element size
  // "counter": the instrumented shaders counted it; "derived": computed from
  // counted events (depth writes = fragment invocations, index fetches = indices drawn).
  std::string source = "counter";
};

struct PassResult {
  std::string name;        // part of the result format: "gbuffer", "lighting", ...
  double gpuMs = 0;        // from timestamps around the pass
  uint64_t fragmentInvocations = 0;           // counted (the fragment shaders' invocation sites)
  int64_t fragmentInvocationsStatistic = -1;  // pipeline statistics; -1 if not queried
  std::vector<Access> accesses;
  uint64_t maxSlotCount = 0;    // the largest single counter slot this frame (0 uninstrumented)
  std::string maxSlotResource;  // what that slot counts
};

struct FrameResult {
  std::vector<PassResult> passes;
};

// A fixed depth range for the projection (metres).
struct DepthRange {
  float zNear = 0.0f;  // > 0
  float zFar = 0.0f;   // > zNear
};

// How the visibility-buffer shading passes pick a pixel's material maps
// (the material is known only per pixel there; docs/measurement.md, "Sweep:
// material edges"). Renderers that bind maps per draw ignore it.
enum class MaterialSelection {
  // The nonuniformEXT index (descriptor indexing), or the per-pixel layer
  // (map arrays): correct per pixel.
  NonUniform,
  // The same index without nonuniformEXT, as the founding study wrote it:
  // undefined unless the index is dynamically uniform, so what is measured is
  // the driver's behaviour. Needs the descriptor-indexing path.
  Uniform,
  // subgroupBroadcastFirst(index): every lane takes the first active lane's
  // maps, a model of a driver that scalarises a non-uniform index. Needs
  // subgroup ballot in fragment shaders; both map paths.
  FirstLane,
};
std::string_view toString(MaterialSelection selection);  // "nonuniform", "uniform", "first-lane"
// Empty for an unknown name.
std::optional<MaterialSelection> parseMaterialSelection(std::string_view name);

// What the fat visibility buffer ("visbuffer") stores per pixel
// (docs/measurement.md, "Sweep: barycentric and derivative precision"). The
// defaults are the renderer's own packing: two R32G32_UINT targets. Other
// renderers ignore it.
enum class BarycentricEncoding {
  Unorm16,  // packUnorm2x16(b1, b2) beside the id: R32G32_UINT
  // The float bits of b1, b2 beside the id: R32G32B32_UINT where the device
  // renders to it, else R32G32B32A32_UINT.
  Float32,
};
enum class UvDerivativeEncoding {
  Half,            // packHalf2x16(dFdx(uv)), packHalf2x16(dFdy(uv)): R32G32_UINT
  // packUnorm2x16 of each, as the founding study stored them: components
  // clamped to [0, 1] (negative ones become 0), then 16-bit steps of 1/65535.
  Unorm16Clamped,
  Float32,         // the float bits of dFdx(uv), dFdy(uv): R32G32B32A32_UINT
};
struct VisibilityEncoding {
  BarycentricEncoding barycentrics = BarycentricEncoding::Unorm16;
  UvDerivativeEncoding uvDerivatives = UvDerivativeEncoding::Half;
  bool operator==(const VisibilityEncoding&) const = default;
};
std::string_view toString(BarycentricEncoding encoding);   // "unorm16", "float32"
std::string_view toString(UvDerivativeEncoding encoding);  // "half", "unorm16-clamped", "float32"
// Empty for an unknown name.
std::optional<BarycentricEncoding> parseBarycentricEncoding(std::string_view name);
std::optional<UvDerivativeEncoding> parseUvDerivativeEncoding(std::string_view name);

// What forward's geometry pass outputs (docs/techniques.md, "Overdraw and
// overshading"). Every mode shades as today; the counting modes add 1 per
// fragment to an R32_SFLOAT count target and show the counts as a heat ramp.
enum class ForwardOutput {
  Shaded,       // the renderer as it is
  Overdraw,     // depth test and write off: every rasterized fragment is counted
  Overshading,  // the shaded mode's depth test: fragments that pass early depth
};
std::string_view toString(ForwardOutput output);  // "shaded", "overdraw", "overshading"
std::optional<ForwardOutput> parseForwardOutput(std::string_view name);  // empty for an unknown name

// Bloom (docs/techniques.md, "Bloom"): a bright pass into an RGBA16F target,
// a Gaussian blur of it, added to the HDR colour by tonemap. The blurs are the
// measured variants; Off leaves every renderer as it was (no bloom passes).
enum class BloomBlur {
  Off,
  Naive,      // one pass, N x N texel fetches per pixel
  Separable,  // horizontal then vertical pass, N fetches each
  Bilinear,   // the same two passes, (N + 1) / 2 linear-filtered taps each
};
std::string_view toString(BloomBlur blur);  // "off", "naive", "separable", "bilinear"
std::optional<BloomBlur> parseBloomBlur(std::string_view name);
struct BloomOptions {
  BloomBlur blur = BloomBlur::Off;
  uint32_t taps = 9;       // odd kernel width N; sigma = N / 6 (renderers/bloom.hpp)
  float threshold = 1.0f;  // HDR luminance above which a pixel blooms
};

struct RendererOptions {
  VkExtent2D extent = {320, 180};
  bool instrumented = true;  // false: the uninstrumented twin, for timing
  spirv::Mode counting;      // exact | subgroup | sampled:N
  uint32_t lights = 400;     // point lights, as in the founding study
  DepthRange depthRange;     // unset (zeros): near/far from the scene bounds (projection.hpp)
  MaterialSelection materialSelection = MaterialSelection::NonUniform;  // visibility-buffer shading passes
  VisibilityEncoding visibility;  // the fat visibility buffer's barycentrics and uv derivatives
  BloomOptions bloom;             // bloom's blur variant, kernel width and threshold (all renderers)
  ForwardOutput forwardOutput = ForwardOutput::Shaded;  // forward, forward-zprepass
  // A depth-only pre-pass before the geometry pass (forward, deferred), which
  // then tests depth EQUAL without writing it: each covered pixel shaded once.
  bool zprepass = false;
};

class Renderer {
 public:
  virtual ~Renderer() = default;
  virtual std::string_view name() const = 0;
  // Pass names in execution order (they are part of the result format).
  virtual std::vector<std::string> passNames() const = 0;
  // Creates targets, pipelines (instrumented or not) and descriptor sets. A
  // failure names the reason (an unsupported feature, a scene too large).
  virtual Result<bool> setup(gpu::Context& ctx, const GpuScene& scene, const RendererOptions& options) = 0;
  // Every resource the renderer created or reads, after setup.
  virtual std::vector<ResourceInfo> resources() const = 0;
  // Records, submits and waits for one frame from `camera`; reads back (and
  // resets) the counters, timestamps and statistics.
  virtual FrameResult renderFrame(const scenes::Camera& camera) = 0;
  // The final image of the last frame, RGBA8, width x height x 4, top row first.
  virtual std::vector<uint8_t> finalImage() = 0;
  // The depth aspect of the depth/stencil target after the last frame,
  // width x height floats, top row first; empty where there is none.
  virtual std::vector<float> depthImage() { return {}; }
  // The texels of the target named `resourceName` (its ResourceInfo name)
  // after the last frame, width x height x the format's bytes, top row first;
  // empty where there is no such target or it was not created readable
  // (transfer_src usage: "final", "depth", the visibility ids and the fat
  // visibility buffer's uv derivatives).
  virtual std::vector<uint8_t> targetBytes(std::string_view resourceName) {
    (void)resourceName;
    return {};
  }
  // Technique measurements of the last frame, e.g. {"overdraw": {...}}: the
  // runner stores them with the sample as "extras".
  virtual nlohmann::json frameExtras() { return nlohmann::json::object(); }
  // What the renderer decided at setup, e.g. {"barycentrics":"extension"}.
  virtual nlohmann::json notes() const { return nlohmann::json::object(); }
  virtual void destroy() = 0;
};

// Where the renderers' GLSL is read from: $TALLY_SHADER_DIR, else the source tree's shaders/.
std::string shaderDirectory();

// "forward", "forward-zprepass", "deferred", "visbuffer", "visbuffer-lean".
std::vector<std::string> rendererNames();
Result<std::unique_ptr<Renderer>> makeRenderer(std::string_view name);

}  // namespace tally::renderers

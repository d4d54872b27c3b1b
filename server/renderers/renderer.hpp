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
#include "gpu/debug_names.hpp"
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
  uint32_t samples = 1;            // images: VkImageCreateInfo::samples (MSAA targets > 1); 1 for buffers
  uint64_t allocationBytes = 0;    // VkMemoryRequirements::size of the real allocation(s)
  std::string usage;               // e.g. "color_attachment|sampled"
  // Images: the memory type the allocation came from, "device_local",
  // "lazily_allocated" (transient attachments where the device offers it) or
  // "host_visible" (a type without DEVICE_LOCAL); "" for buffers.
  std::string memory;
  // The images or buffers whose accesses count under `name`: one for a
  // target or a buffer; every texture of a map kind and its dummy for
  // "material_maps.<kind>" (with the visibility buffers' map arrays, the
  // kind's layered image first: the per-texture images are bound by their
  // alpha-tested and transparent draws); both materials buffers where the
  // descriptor-indexing path binds its own. Setup names each one `name`
  // through VK_EXT_debug_utils (gpu/debug_names.hpp).
  std::vector<gpu::DebugObject> objects;
};

// One line of a pass's traffic: a resource read or written.
struct Access {
  std::string resource;  // ResourceInfo::name
  // How the pass uses it (spirv::useKind: "texture", "storage image",
  // "attachment", "depth", "buffer"); "": the resource's own kind (derived lines).
  std::string kind;
  bool write = false;
  uint64_t count = 0;    // events (counter totals, or derived: see source)
  uint64_t bytes = 0;    // count x element size
  // "counter": the instrumented shaders counted it; "derived": computed from
  // counted events (depth writes = fragment invocations, index fetches = indices drawn).
  std::string source = "counter";
  // The tile-memory byte model (docs/measurement.md, "Byte models"): true
  // where a tile-based GPU keeps this traffic on chip (writes of a DONT_CARE
  // attachment, input-attachment reads within the render pass), 0 DRAM bytes.
  bool onChip = false;
  // Footprint (docs/measurement.md, "Footprint"): distinct bytes this line
  // touched in the frame, in blocks of RendererOptions::footprintBlockBytes
  // (the union of every block any access of the line covered). -1 where it
  // was not measured (footprint off, or a line the model cannot see).
  int64_t footprintBytes = -1;
  // The blocks behind footprintBytes (x the block size may exceed bytes:
  // footprintBytes is the smaller of the two). -1 where not measured.
  int64_t footprintBlocks = -1;
  // footprintBlocks x the block size exceeded the requested bytes, so
  // footprintBytes was clamped to them (accesses sparser than a block).
  bool footprintClamped = false;
};

// One access site's count in a frame (RendererOptions::sites): which
// instruction of which shader, and the line (resource and direction) it
// counts toward. A site with a dynamic descriptor index has one entry per
// element it reached, each under that element's resource.
struct SiteCount {
  spirv::Site site;  // shader (the GLSL file), instruction, source line
  std::string resource, kind;  // as the Access it adds to
  bool write = false;
  uint64_t count = 0, bytes = 0;
};

// One draw's share of a pass's counted lines (RendererOptions::draws): a
// scene draw (one mesh primitive with its material), or with `draws` > 1 the
// draws beyond RendererOptions::maxCountedDraws, which share one count.
struct DrawCount {
  uint32_t index = 0;          // the scene's draw (mesh) index; the first of the rest
  std::string mesh, material;  // the mesh's name (its index where unnamed) and its material's
  uint32_t draws = 1;
  uint64_t count = 0, bytesRead = 0, bytesWritten = 0;
};

// One material's bytes in a pass: the sum over its draws (geometry passes),
// or on the visibility buffers' shading passes its share of the material-map
// reads (the textures only it samples; a texture several materials share is
// one entry naming them all).
struct MaterialCount {
  std::string material;
  uint32_t draws = 0;  // the draws summed; on shading passes the scene's draws with the material
  uint64_t count = 0, bytesRead = 0, bytesWritten = 0;
};

struct PassResult {
  std::string name;        // part of the result format: "gbuffer", "lighting", ...
  double gpuMs = 0;        // from timestamps around the pass
  uint64_t fragmentInvocations = 0;           // counted (the fragment shaders' invocation sites)
  int64_t fragmentInvocationsStatistic = -1;  // pipeline statistics; -1 if not queried
  uint64_t computeInvocations = 0;            // counted (the compute shaders' invocation sites)
  int64_t computeInvocationsStatistic = -1;   // pipeline statistics; -1 if not queried
  std::vector<Access> accesses;
  uint64_t maxSlotCount = 0;    // the largest single counter slot this frame (0 uninstrumented)
  std::string maxSlotResource;  // what that slot counts
  // Arithmetic operations this frame (docs/measurement.md, "Arithmetic per
  // pass"): counted as executed in the accumulate mode (arithmeticCounted),
  // else an estimate: each shader's static count per invocation
  // (spirv/arith.hpp) x its counted invocations, summed over the pass's
  // shaders. -1 where unknown (uninstrumented frames, no shader).
  int64_t arithmeticOps = -1;
  bool arithmeticCounted = false;
  // RendererOptions::sites: every counted access site of the pass's shaders;
  // a line's count and bytes are the sums over its sites.
  std::vector<SiteCount> sites;
  // RendererOptions::draws: every draw the pass recorded (its counted lines
  // split per draw; they sum to the pass's counted lines), the rest beyond
  // the cap (draws == 0: none), and the per-material sums.
  std::vector<DrawCount> draws;
  DrawCount drawsRest = {.draws = 0};
  std::vector<MaterialCount> materials;
};

struct FrameResult {
  std::vector<PassResult> passes;
  // Host wall time of the frame: recording, submitting and waiting for the
  // GPU; then reading back timestamps, statistics and counters (seconds).
  double submitSeconds = 0, readbackSeconds = 0;
};

// Where a renderer's set-up time went (seconds): GLSL compilation with
// instrumentation, and pipeline creation (the driver's compiler).
struct SetupTimes {
  double shaderSeconds = 0, pipelineSeconds = 0;
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
  // Mesh density (docs/techniques.md, "Mesh density"): each fragment coloured
  // by its triangle's screen-space class (sub-pixel, long-thin, normal); the
  // fragments and quad lanes (helpers included) counted per pixel.
  Density,
};
std::string_view toString(ForwardOutput output);  // "shaded", "overdraw", "overshading", "density"
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
  uint32_t taps = 9;       // odd kernel width N; sigma = N / 6 (renderers/techniques/bloom.hpp)
  float threshold = 1.0f;  // HDR luminance above which a pixel blooms
};

// Shadow mapping (docs/techniques.md, "Shadow mapping"; renderers/techniques/shadows.hpp):
// one directional sun, a depth-only "shadow" pass into a D32_SFLOAT map, read
// by every shading pass. Off leaves every renderer as it was (no sun, no pass).
enum class ShadowFilter {
  Off,
  Hard,    // one nearest depth-compare tap
  Pcf2x2,  // one linear depth-compare tap (hardware 2x2 PCF)
  Pcf4x4,  // four linear compare taps at +-1 texel: a 4x4 texel footprint
};
struct ShadowOptions {
  ShadowFilter filter = ShadowFilter::Off;
  uint32_t mapSize = 2048;  // texels per side
  float bias = 1.5f;        // in shadow-map texels (world size of one), times 1 + tan(slope)
  float sunDirection[3] = {-0.35f, 1.0f, 0.25f};  // towards the sun (world, +Y up); normalised at setup
};

// How vertices carry their tangent frame (docs/techniques.md, "Packed tangent
// frames"; renderers/techniques/tbn.hpp): Float, shaders::Vertex's float normal and
// tangent (48-byte vertices); Quaternion, a packed 24-byte vertex buffer with
// the frame as a 24-bit unit quaternion, read by every vertex path.
enum class TangentFrameEncoding { Float, Quaternion };

// The compute workloads (docs/techniques.md, "Volume fog", "Ray tracer";
// renderers/workloads/workloads.hpp). Renderers ignore them.
enum class FogOctaves {
  Fixed,     // loop to maxOctaves read from a uniform: the reference
  Dynamic,   // clamp(max - floor(log2(t / t0)), 1, max): a runtime loop bound from distance
  Constant,  // the max as a compile-time #define: the compiler may unroll
};
struct WorkloadOptions {
  FogOctaves fogOctaves = FogOctaves::Fixed;
  uint32_t fogSteps = 64;        // samples per ray between the box's entry and exit
  uint32_t fogMaxOctaves = 6;    // 1..8
  float fogDensity = 1.0f;       // extinction scale (per scene diagonal); 0: transparent
  uint32_t spheres = 32;         // raytrace: sphere count
  uint32_t bounces = 1;          // raytrace: specular reflection rays per hit chain, 0..3
};

struct RendererOptions {
  VkExtent2D extent = {320, 180};
  bool instrumented = true;  // false: the uninstrumented twin, for timing
  spirv::Mode counting{spirv::CountMode::Accumulate};  // the capture spec's default; exact | subgroup | sampled:N | accumulate...
  uint32_t lights = 400;     // point lights, as in the founding study
  DepthRange depthRange;     // unset (zeros): near/far from the scene bounds (projection.hpp)
  MaterialSelection materialSelection = MaterialSelection::NonUniform;  // visibility-buffer shading passes
  VisibilityEncoding visibility;  // the fat visibility buffer's barycentrics and uv derivatives
  BloomOptions bloom;             // bloom's blur variant, kernel width and threshold (all renderers)
  ForwardOutput forwardOutput = ForwardOutput::Shaded;  // forward, forward-zprepass
  // A depth-only pre-pass before the geometry pass (forward, deferred), which
  // then tests depth EQUAL without writing it: each covered pixel shaded once.
  bool zprepass = false;
  TangentFrameEncoding tangentFrame = TangentFrameEncoding::Float;  // every renderer
  // Levels of detail (docs/techniques.md, "Levels of detail"; renderers/techniques/lod.hpp):
  // 0 off, else the pixel threshold: per draw, per frame, the coarsest
  // meshoptimizer level whose projected error is at most this many pixels.
  float lodThresholdPx = 0.0f;
  // Deferred's G-buffer (docs/techniques.md, "Tile memory"): false, two render
  // passes, lighting samples it; true, one render pass of two subpasses,
  // transient attachments read by subpassLoad.
  bool gbufferSubpass = false;
  // MSAA sample count of the geometry pass's targets and depth (deferred,
  // visbuffer, visbuffer-lean): 1, 2, 4 or 8; the shading pass resolves into
  // the 1-sample "hdr" (docs/techniques.md, "MSAA footprint"; renderers/techniques/msaa.hpp).
  uint32_t msaa = 1;
  ShadowOptions shadows;  // shadow mapping (all renderers); filter Off: none
  // Shading in compute (deferred, visbuffer, visbuffer-lean; docs/techniques.md,
  // "Shading in compute"): the "lighting" / "shading" pass as a compute
  // dispatch (8x8 workgroups) that imageStores "hdr", instead of a full-screen
  // fragment pass. False: the fragment pass as it was.
  bool computeShading = false;
  WorkloadOptions workload;  // the compute workloads' parameters (volume-fog, raytrace)
  // Footprint counting (docs/measurement.md, "Footprint"): 0 off, else the
  // block size in bytes (32, 64 or 128) of the per-resource bitmaps that
  // mark which blocks each access touches. Needs instrumented.
  uint32_t footprintBlockBytes = 0;
  // Counts per access site (spirv::InstrumentOptions::perSite), shaders
  // compiled with line information: PassResult::sites. Needs instrumented.
  bool sites = false;
  // Counts per draw and per material (PassResult::draws, ::materials): each
  // scene draw counts into a counter region of its own, up to
  // maxCountedDraws draws; the draws beyond share one more region. Needs
  // instrumented.
  bool draws = false;
  uint32_t maxCountedDraws = 1024;
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
  // After setup: what the driver reports of each pass's pipelines (register
  // count, local memory, ...: gpu::executableStatistics), as
  // [{"pass", "stages", "executable", "statistics": {name: value}}]; empty
  // where the device does not report them.
  virtual nlohmann::json pipelineStatistics() const { return nlohmann::json::array(); }
  // Since the last setup().
  virtual SetupTimes setupTimes() const { return {}; }
  // After setup: the most descriptor sets any of its pipeline layouts holds
  // (the counter set's index + 1 when instrumented; uninstrumented ones stop
  // at the last set their shaders use). 0 where unknown.
  virtual uint32_t maxPipelineSetCount() const { return 0; }
  virtual void destroy() = 0;
};

// Where the renderers' GLSL is read from: $TALLY_SHADER_DIR (for shaders
// being worked on), else the data folder's shaders/ (common/paths.hpp).
Result<std::string> shaderDirectory();

// "forward", "forward-zprepass", "deferred", "visbuffer", "visbuffer-lean".
std::vector<std::string> rendererNames();
// The compute workloads, made by makeRenderer like renderers but listed apart:
// "volume-fog", "raytrace" (capture specs' "workloads").
std::vector<std::string> workloadNames();
bool isWorkload(std::string_view name);
Result<std::unique_ptr<Renderer>> makeRenderer(std::string_view name);

}  // namespace tally::renderers

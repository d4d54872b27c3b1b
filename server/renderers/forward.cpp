// Forward rendering: one geometry pass samples the draw's five maps and
// shades every light per fragment that passes the early depth test.
// "forward-zprepass" (or forward with zprepass=true) first lays depth down
// with a position-only pass, so the forward pass (depth EQUAL, no depth
// write) shades each covered pixel once.
// output=overdraw|overshading: the forward pass also adds 1 per fragment to
// "overdraw.count" (R32_SFLOAT, additive blending; depth test off for
// overdraw, as shaded for overshading), an "overdraw_view" pass turns the
// counts into a heat ramp in "hdr", and frameExtras() gives their per-pixel
// histogram checked against the counted fragment invocations.
// output=density: the forward pass (depth test as shaded) colours each
// fragment by its triangle's screen-space class (shaders/density.h) instead
// of its shading, counts fragments into "overdraw.count" and quad lanes
// (helpers included, subgroup quad operations) into "density.lanes"; no heat
// view. frameExtras() adds a CPU census of the triangles (renderers/techniques/density.hpp).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>

#include "renderers/techniques/density.hpp"
#include "renderers/renderers.hpp"
#include "shared.h"

namespace tally::renderers {
namespace {

constexpr VkFormat kCountFormat = VK_FORMAT_R32_SFLOAT;
// R32_SFLOAT adds 1.0 exactly up to 2^24 fragments on one pixel (the 24-bit
// significand); R16_SFLOAT would stop at 2048, which a dense scene's
// overdraw of a few pixels can reach. Integer formats do not blend.
constexpr uint64_t kCountExactLimit = uint64_t(1) << 24;
constexpr uint32_t kStencilBytes = 1;  // the S8 aspect of D32_SFLOAT_S8_UINT

class ForwardRenderer final : public RendererBase {
 public:
  explicit ForwardRenderer(bool prepass) : prepassRenderer_(prepass) {}
  std::string_view name() const override { return prepassRenderer_ ? "forward-zprepass" : "forward"; }
  nlohmann::json notes() const override {
    nlohmann::json out = nlohmann::json::object();
    // Instrumented runs give the pre-pass an empty fragment shader
    // (zprepass.frag) so that its depth writes are counted; the timing twin
    // stays depth-only.
    if (prepass()) out["zprepass_fragment_shader"] = options_.instrumented ? "counting_only" : "none";
    if (density()) {
      out["density_lanes"] = quadOps_ ? "gpu_quad_ops (helper lanes: gl_HelperInvocation)"
                             : helperByMask_ ? "cpu_raster_no_depth (llvmpipe: helper lanes not observable)"
                                             : "cpu_raster_no_depth (no subgroup quad operations in fragment shaders)";
    }
    return out;
  }
  nlohmann::json frameExtras() override;

 protected:
  std::vector<std::string> ownPassNames() const override {
    std::vector<std::string> names;
    if (prepass()) names.push_back("zprepass");
    names.push_back("forward");
    if (heatView()) names.push_back("overdraw_view");
    return names;
  }

  Result<bool> setupPasses() override;
  FrameResult finishFrame(FrameResult frame) override;

 private:
  bool prepass() const { return prepassRenderer_ || options_.zprepass; }
  bool counting() const { return options_.forwardOutput != ForwardOutput::Shaded; }
  bool overdraw() const { return options_.forwardOutput == ForwardOutput::Overdraw; }
  bool density() const { return options_.forwardOutput == ForwardOutput::Density; }
  bool heatView() const { return counting() && !density(); }  // overdraw, overshading
  nlohmann::json densityExtras();
  Result<bool> setupOverdrawView(const gpu::Image* count);

  bool prepassRenderer_;
  uint64_t countedFragments_ = 0;      // the forward pass's counted fragment invocations, last frame
  int64_t statisticFragments_ = -1;    // its pipeline statistic; -1 not queried
  bool quadOps_ = false;               // density: subgroup quad operations in fragment shaders
  bool helperByMask_ = false;          // density: helper lanes by gl_SampleMaskIn (llvmpipe)
};

Result<bool> ForwardRenderer::setupPasses() {
  for (auto& r : scene_->materialMapResources()) resources_.push_back(r);
  const VkImageLayout depthAttachment = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  const VkImageLayout depthReadOnly = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  const gpu::Image* count = nullptr;
  if (counting()) {
    VkFormatProperties props = {};
    vkGetPhysicalDeviceFormatProperties(ctx_->physicalDevice, kCountFormat, &props);
    if ((props.optimalTilingFeatures & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BLEND_BIT) == 0) {
      return makeError("output=" + std::string(toString(options_.forwardOutput)) +
                       ": the device cannot blend R32_SFLOAT colour attachments (the count target)");
    }
    count = createTarget("overdraw.count", kCountFormat,
                         VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                             VK_IMAGE_USAGE_TRANSFER_SRC_BIT,  // frameExtras() reads it back
                         ResourceKind::Attachment);
  }
  const gpu::Image* lanes = nullptr;
  if (density()) {
    lanes = createTarget("density.lanes", kCountFormat,
                         VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, ResourceKind::Attachment);
    VkPhysicalDeviceSubgroupProperties subgroup = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
    VkPhysicalDeviceProperties2 props = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    props.pNext = &subgroup;
    vkGetPhysicalDeviceProperties2(ctx_->physicalDevice, &props);
    quadOps_ = (subgroup.supportedStages & VK_SHADER_STAGE_FRAGMENT_BIT) != 0 &&
               (subgroup.supportedOperations & VK_SUBGROUP_FEATURE_QUAD_BIT) != 0;
    // llvmpipe cannot compile gl_HelperInvocation (is_helper_invocation):
    // there a helper lane is one with no covered sample (density.h).
    VkPhysicalDeviceDriverProperties driver = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 driverProps = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    driverProps.pNext = &driver;
    vkGetPhysicalDeviceProperties2(ctx_->physicalDevice, &driverProps);
    // llvmpipe: gl_HelperInvocation does not compile and gl_SampleMaskIn
    // does not mark its helper lanes (measured 1 lane per covered pixel on
    // isolated pixels): lanes come from the CPU estimate there.
    helperByMask_ = driver.driverID == VK_DRIVER_ID_MESA_LLVMPIPE;
    if (helperByMask_) quadOps_ = false;
  }
  if (prepass()) {
    if (auto ok = addDepthPrepass(); !ok) return ok;
  }
  uint32_t p = addPass("forward");
  AttachmentSpec depth{kDepthFormat, true, VK_IMAGE_LAYOUT_UNDEFINED, depthAttachment, depthReadOnly};
  if (prepass()) depth = {kDepthFormat, false, depthAttachment, depthAttachment, depthReadOnly};
  std::vector<AttachmentSpec> colors = {{kHdrFormat}};
  if (counting()) colors.push_back({kCountFormat});  // cleared to 0 each frame
  if (density()) colors.push_back({kCountFormat});   // density.lanes, cleared to 0
  VkRenderPass rp = ownRenderPass(createPassRenderPass(*ctx_, colors, depth));
  std::vector<VkImageView> views = {hdr_->view};
  if (counting()) views.push_back(count->view);
  if (density()) views.push_back(lanes->view);
  views.push_back(depth_->view);
  VkFramebuffer fb = framebuffer(rp, views);
  std::vector<std::string> defines;
  if (counting()) defines.push_back("TALLY_COUNT_FRAGMENTS");
  if (density()) defines.push_back("TALLY_DENSITY");
  if (density() && quadOps_) defines.push_back("TALLY_DENSITY_QUADS");
  auto shaders = shaderPipeline(p, "forward.vert.glsl", "forward.frag.glsl",
                                pipelineLayout(materialLayout_, VK_NULL_HANDLE), rp, defines);
  if (!shaders) return makeError(shaders.error());
  gpu::GraphicsPipelineDesc desc = *shaders;
  meshVertexInput(desc);
  geometryState(desc, !prepass());
  if (prepass()) desc.depthCompare = VK_COMPARE_OP_EQUAL;  // bit-identical depth (`invariant`)
  if (counting()) {
    desc.colorAttachmentCount = density() ? 3 : 2;
    // One blend state for both outputs: hdr's alpha 1 replaces, the count's alpha 0 adds.
    desc.blend = true;
    // Overdraw: no depth test, so every rasterized fragment is shaded and
    // counted; the stencil still marks geometry for the skybox.
    if (overdraw()) desc.depthTest = desc.depthWrite = false;
  }
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
    pass(p).bindings.bind(shaders::kSetMaterial, k, std::string("material_maps.") + mapKindName(k));
  }
  pass(p).bindings.outputs[shaders::kOutColor] = "hdr";
  if (counting()) pass(p).bindings.outputs[shaders::kOutCount] = "overdraw.count";
  if (density()) pass(p).bindings.outputs[shaders::kOutCount + 1] = "density.lanes";
  pass(p).indexFetches = true;
  if (!prepass() && !overdraw()) pass(p).depthWrite = "depth";  // overdraw: finishFrame adds the stencil writes
  if (scene_->features().emissiveMaps) {
    pass(p).bindings.bind(shaders::kSetMaterial, shaders::kBindingEmissiveMap, "material_maps.emissive");
  }
  const size_t clearCount = colors.size() + 1;
  auto masked = maskedDraws(p, desc, "forward.vert.glsl", "forward.frag.glsl", defines);
  if (!masked) return makeError(masked.error());
  pass(p).record = [=, this, masked = *masked](VkCommandBuffer cmd) {
    std::vector<VkClearValue> clears(clearCount);  // colours 0 (no fragments yet)
    clears.back() = depthClear();
    beginRenderPass(cmd, p, rp, fb, clears);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, VK_NULL_HANDLE, VK_NULL_HANDLE);
    drawScene(cmd, p, layout, true);
    if (masked) masked(cmd);
    endRenderPass(cmd, p);
  };
  if (heatView()) return setupOverdrawView(count);
  return true;
}

// Full screen, every pixel (no depth/stencil): the count texel to a heat
// ramp in hdr, replacing the shaded colours; the skybox still paints the
// pixels no geometry covered.
Result<bool> ForwardRenderer::setupOverdrawView(const gpu::Image* count) {
  uint32_t p = addPass("overdraw_view");
  VkDescriptorSetLayout inputLayout = setLayout({VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER});
  VkDescriptorSet input = allocateSet(inputLayout);
  writeImage(input, shaders::kBindingCountTarget, count->view, targetSampler_,
             VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  pass(p).bindings.bind(shaders::kSetPassInput, shaders::kBindingCountTarget, "overdraw.count");
  pass(p).bindings.outputs[shaders::kOutColor] = "hdr";
  VkRenderPass rp = ownRenderPass(createPassRenderPass(*ctx_, {{kHdrFormat}}, std::nullopt));
  VkFramebuffer fb = framebuffer(rp, {hdr_->view});
  auto shaders = shaderPipeline(p, "fullscreen.vert.glsl", "overdraw_view.frag.glsl",
                                pipelineLayout(VK_NULL_HANDLE, inputLayout), rp);
  if (!shaders) return makeError(shaders.error());
  gpu::GraphicsPipelineDesc desc = *shaders;
  VkPipeline pipe = pipeline(desc);
  VkPipelineLayout layout = desc.layout;
  pass(p).record = [=, this](VkCommandBuffer cmd) {
    beginRenderPass(cmd, p, rp, fb, {VkClearValue{}});
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
    bindSets(cmd, layout, VK_NULL_HANDLE, input);
    drawFullScreen(cmd);
    endRenderPass(cmd, p);
  };
  return true;
}

FrameResult ForwardRenderer::finishFrame(FrameResult frame) {
  for (auto& r : frame.passes) {
    if (r.name != "forward") continue;
    countedFragments_ = r.fragmentInvocations;
    statisticFragments_ = r.fragmentInvocationsStatistic;
    if (!counting() || !options_.instrumented) break;
    // Blending reads the destination texel of every output it writes
    // (docs/measurement.md): a read per counted write, of the same size.
    std::vector<Access> blendReads;
    for (const auto& a : r.accesses) {
      if (a.write && a.source == "counter" &&
          (a.resource == "hdr" || a.resource == "overdraw.count" || a.resource == "density.lanes")) {
        blendReads.push_back(a);
      }
    }
    for (const auto& a : blendReads) {
      addAccess(r.accesses, a.resource, false, a.count, a.count ? a.bytes / a.count : 0, "derived");
    }
    // Overdraw writes no depth, but every fragment sets the stencil.
    if (overdraw() && !prepass()) addAccess(r.accesses, "depth", true, r.fragmentInvocations, kStencilBytes, "derived");
  }
  return frame;
}

nlohmann::json ForwardRenderer::frameExtras() {
  nlohmann::json extras = RendererBase::frameExtras();  // the shared post chain's (bloom)
  if (!counting()) return extras;
  if (density()) {
    extras["density"] = densityExtras();
    return extras;
  }
  const std::vector<uint8_t> bytes = targetBytes("overdraw.count");
  std::map<uint64_t, uint64_t> pixelsWith;  // count -> pixels
  uint64_t fragments = 0, covered = 0, max = 0;
  bool exact = true;
  for (size_t i = 0; i + sizeof(float) <= bytes.size(); i += sizeof(float)) {
    float v;
    std::memcpy(&v, bytes.data() + i, sizeof v);
    const uint64_t n = v > 0 ? uint64_t(std::llround(v)) : 0;
    if (double(n) != double(v) || n >= kCountExactLimit) exact = false;
    ++pixelsWith[n];
    fragments += n;
    if (n > 0) ++covered;
    max = std::max(max, n);
  }
  nlohmann::json histogram = nlohmann::json::array();
  for (const auto& [n, pixels] : pixelsWith) histogram.push_back({{"count", n}, {"pixels", pixels}});
  nlohmann::json out = {{"mode", toString(options_.forwardOutput)},
                        {"histogram", histogram},
                        {"covered_pixels", covered},
                        {"fragments", fragments},
                        {"mean_per_covered_pixel", covered ? double(fragments) / double(covered) : 0.0},
                        {"max", max},
                        {"counts_exact", exact},  // every texel an integer below 2^24
                        {"statistic_fragments", nullptr},
                        {"counted_fragments", nullptr},
                        {"agrees", nullptr}};
  if (statisticFragments_ >= 0) out["statistic_fragments"] = statisticFragments_;
  if (options_.instrumented) {
    out["counted_fragments"] = countedFragments_;
    out["agrees"] = exact && fragments == countedFragments_;
  }
  extras["overdraw"] = out;
  return extras;
}

nlohmann::json ForwardRenderer::densityExtras() {
  const density::Census census = density::census(*scene_, frameCamera_.viewProj, extent_);
  return density::extras(census, targetBytes("overdraw.count"), targetBytes("density.lanes"), quadOps_, finalImage(),
                         countedFragments_, options_.instrumented);
}

}  // namespace

std::unique_ptr<Renderer> makeForward(bool prepass) { return std::make_unique<ForwardRenderer>(prepass); }

}  // namespace tally::renderers

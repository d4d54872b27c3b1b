// What every renderer shares: the frame, material, geometry and counter
// descriptor sets; the HDR, final (RGBA8 sRGB) and depth/stencil targets; the
// tonemap and skybox passes; per-pass timestamps, statistics and counter
// attribution; shader compilation (instrumented or not) with one counter
// buffer for all passes. A renderer adds its own passes in setupPasses().
#pragma once

#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "gpu/pipelines.hpp"
#include "gpu/queries.hpp"
#include "gpu/resources.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/pass_counters.hpp"
#include "renderers/renderer.hpp"

namespace tally::renderers {

constexpr VkFormat kHdrFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kFinalFormat = VK_FORMAT_R8G8B8A8_SRGB;  // tonemap.frag writes linear; the store encodes
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT_S8_UINT;
constexpr uint32_t kStencilGeometry = 1;  // geometry passes write it; sky pixels keep the cleared 0

// One attachment of a render pass.
struct AttachmentSpec {
  VkFormat format = VK_FORMAT_UNDEFINED;
  bool clear = true;  // else load
  VkImageLayout initial = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImageLayout layout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;  // during the subpass
  VkImageLayout final = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
};

// One subpass; external dependencies make each render pass wait for all
// earlier work and later work wait for it (passes run one after another).
VkRenderPass createPassRenderPass(const gpu::Context& ctx, const std::vector<AttachmentSpec>& colors,
                                  std::optional<AttachmentSpec> depth);

class RendererBase : public Renderer {
 public:
  ~RendererBase() override { destroy(); }
  Result<bool> setup(gpu::Context& ctx, const GpuScene& scene, const RendererOptions& options) final;
  std::vector<ResourceInfo> resources() const override { return resources_; }
  FrameResult renderFrame(const scenes::Camera& camera) final;
  std::vector<uint8_t> finalImage() override;
  std::vector<float> depthImage() override;
  std::vector<uint8_t> targetBytes(std::string_view resourceName) override;
  void destroy() override;
  std::vector<std::string> passNames() const override;
  // {"bloom": {...}} with bloom on (setupBloom), else {}. A renderer that adds
  // its own extras merges these in.
  nlohmann::json frameExtras() override;

 protected:
  // A pass: its name, how it records (between the base's timestamps), what
  // it bound (for attribution) and the sites of its shaders.
  struct Pass {
    std::string name;
    std::function<void(VkCommandBuffer)> record;
    PassBindings bindings;
    std::vector<spirv::Site> sites;
    std::string depthWrite;     // resource whose depth/stencil the pass writes ("" none)
    uint64_t indicesDrawn = 0;  // this frame, by drawScene
    bool indexFetches = false;  // derive "indices" reads from indicesDrawn
  };

  // Derived classes: create targets and pipelines, add passes (in order).
  // The base then adds tonemap (reads "hdr": SHADER_READ_ONLY_OPTIMAL after
  // the renderer's passes) and skybox (needs "depth" in
  // DEPTH_STENCIL_READ_ONLY_OPTIMAL with stencil 1 on geometry).
  virtual Result<bool> setupPasses() = 0;
  virtual void destroyPasses() {}
  // Names of the passes the renderer adds before tonemap and skybox.
  virtual std::vector<std::string> ownPassNames() const = 0;

  uint32_t addPass(std::string name);
  Pass& pass(uint32_t index) { return passes_[index]; }

  // A colour or depth target, recorded as a resource.
  // The image lives until destroy() (stable address).
  const gpu::Image* createTarget(const std::string& name, VkFormat format, VkImageUsageFlags usage,
                                 ResourceKind kind);
  VkImageView depthOnlyView();  // the depth aspect of "depth", for sampling
  VkFramebuffer framebuffer(VkRenderPass renderPass, const std::vector<VkImageView>& views);

  // Compiles <dir>/<file> (with `defines` after #version), instrumented
  // unless options.instrumented is false; the sites go to pass `passIndex`.
  Result<VkShaderModule> shader(uint32_t passIndex, const std::string& file,
                                const std::vector<std::string>& defines = {});
  // The pass's vertex and fragment shaders (each through shader()) in a
  // pipeline description for `layout` and `renderPass`; the caller adds the
  // fixed-function state.
  Result<gpu::GraphicsPipelineDesc> shaderPipeline(uint32_t passIndex, const std::string& vertex,
                                                   const std::string& fragment, VkPipelineLayout layout,
                                                   VkRenderPass renderPass,
                                                   const std::vector<std::string>& fragmentDefines = {});
  // Sets 0 frame, 1 `material` (or empty), 2 geometry, 3 `passInput` (or
  // empty), empty up to the counter set; push constants DrawPush.
  VkPipelineLayout pipelineLayout(VkDescriptorSetLayout material, VkDescriptorSetLayout passInput);
  VkPipeline pipeline(const gpu::GraphicsPipelineDesc& desc);
  // One descriptor per binding, or counts[i] where given (arrays).
  VkDescriptorSetLayout setLayout(const std::vector<VkDescriptorType>& bindings,
                                  const std::vector<uint32_t>& counts = {});
  VkDescriptorSet allocateSet(VkDescriptorSetLayout layout);
  void writeImage(VkDescriptorSet set, uint32_t binding, VkImageView view, VkSampler sampler,
                  VkImageLayout layout);

  // Vertex buffer binding 0 (shaders::Vertex) with the four attributes.
  static void meshVertexInput(gpu::GraphicsPipelineDesc& desc);
  // Frame and geometry sets, `material`/`passInput` where given, counters.
  // `geometry` replaces the scene's geometry set where given.
  void bindSets(VkCommandBuffer cmd, VkPipelineLayout layout, VkDescriptorSet material,
                VkDescriptorSet passInput, VkDescriptorSet geometry = VK_NULL_HANDLE);
  // A geometry set (draws, materials, vertices, indices) with another materials buffer.
  VkDescriptorSet geometrySetWith(const gpu::Buffer& materials);
  // Every draw, push constants and (when materialSets) the draw's material set.
  void drawScene(VkCommandBuffer cmd, uint32_t passIndex, VkPipelineLayout layout, bool materialSets);
  void beginRenderPass(VkCommandBuffer cmd, uint32_t passIndex, VkRenderPass renderPass, VkFramebuffer fb,
                       const std::vector<VkClearValue>& clears);
  void endRenderPass(VkCommandBuffer cmd, uint32_t passIndex);
  void drawFullScreen(VkCommandBuffer cmd) { vkCmdDraw(cmd, 3, 1, 0, 0); }

  // Geometry passes: depth LESS (written when writeDepth), stencil set to
  // kStencilGeometry on every fragment that passes.
  static void geometryState(gpu::GraphicsPipelineDesc& desc, bool writeDepth);
  // A position-only "zprepass" pass clearing and writing "depth"
  // (zprepass.vert; zprepass.frag in instrumented runs, so that its depth
  // writes are counted). The next geometry pass loads depth and tests EQUAL.
  Result<bool> addDepthPrepass();
  // Full-screen shading passes: only pixels the geometry passes marked with
  // kStencilGeometry are shaded (sky pixels are masked out).
  static void geometryPixelsOnly(gpu::GraphicsPipelineDesc& desc);
  static VkClearValue depthClear();  // depth 1 (far), stencil 0
  // After the base has attributed a frame: renderer-specific derived lines.
  virtual FrameResult finishFrame(FrameResult frame) { return frame; }

  // Frame-set and geometry-set bindings every pass may read.
  PassBindings commonBindings() const;

  gpu::Context* ctx_ = nullptr;
  const GpuScene* scene_ = nullptr;
  RendererOptions options_;
  VkExtent2D extent_ = {};
  const gpu::Image* hdr_ = nullptr;
  const gpu::Image* final_ = nullptr;
  const gpu::Image* depth_ = nullptr;
  VkDescriptorSetLayout materialLayout_ = VK_NULL_HANDLE;  // set 1: five sampler2D (per draw)
  VkDescriptorSetLayout mapArrayLayout_ = VK_NULL_HANDLE;  // set 1: five sampler2DArray (per pixel)
  std::vector<VkDescriptorSet> materialSets_;
  VkDescriptorSet mapArraySet_ = VK_NULL_HANDLE;
  VkSampler targetSampler_ = VK_NULL_HANDLE;  // nearest, clamp: texelFetch of targets
  std::vector<ResourceInfo> resources_;

 private:
  void setupTonemapAndSkybox();
  // Bloom's passes before tonemap (options_.bloom; none when off) and its
  // targets: "bloom_bright", "bloom_h" (the two-pass blurs), "bloom".
  void setupBloom();
  std::vector<std::string> bloomPassNames() const;
  void recordAll(VkCommandBuffer cmd);

  std::vector<Pass> passes_;
  uint32_t counterSet_ = 7;
  uint32_t slotCount_ = 0;
  gpu::Buffer counters_, cameraBuffer_, lightingBuffer_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout frameLayout_ = VK_NULL_HANDLE, geometryLayout_ = VK_NULL_HANDLE,
                        emptyLayout_ = VK_NULL_HANDLE, counterLayout_ = VK_NULL_HANDLE;
  VkDescriptorSet frameSet_ = VK_NULL_HANDLE, geometrySet_ = VK_NULL_HANDLE,
                  counterDescriptorSet_ = VK_NULL_HANDLE;
  VkImageView depthOnlyView_ = VK_NULL_HANDLE;
  const gpu::Image* bloom_ = nullptr;  // the blurred bloom tonemap adds; null with bloom off
  VkSampler bloomSampler_ = VK_NULL_HANDLE;  // linear, clamp: the bilinear blur's taps
  nlohmann::json bloomExtras_;               // frameExtras()["bloom"], fixed at setup
  std::vector<VkDescriptorSetLayout> ownedSetLayouts_;
  std::vector<VkPipelineLayout> pipelineLayouts_;
  std::vector<VkPipeline> pipelines_;
  std::vector<VkShaderModule> modules_;
  std::vector<VkRenderPass> renderPasses_;
  std::vector<VkFramebuffer> framebuffers_;
  gpu::TimestampQueries timestamps_;
  gpu::StatisticsQueries statistics_;
  std::deque<gpu::Image> targets_;
  struct TargetName {
    std::string name;
    VkImageUsageFlags usage = 0;
  };
  std::vector<TargetName> targetNames_;  // parallel to targets_
  bool ready_ = false;

 protected:
  // Render passes created by derived classes are destroyed with the renderer.
  VkRenderPass ownRenderPass(VkRenderPass rp) {
    renderPasses_.push_back(rp);
    return rp;
  }
};

}  // namespace tally::renderers

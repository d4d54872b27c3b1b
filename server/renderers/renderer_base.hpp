// What every renderer shares: the frame, material, geometry and counter
// descriptor sets; the HDR, final (RGBA8 sRGB) and depth/stencil targets; the
// tonemap and skybox passes; per-pass timestamps, statistics and counter
// attribution; shader compilation (instrumented or not) with one counter
// buffer for all passes. A renderer adds its own passes in setupPasses().
#pragma once

#include <array>
#include <deque>
#include <functional>
#include <optional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "gpu/footprint.hpp"
#include "gpu/pipelines.hpp"
#include "gpu/queries.hpp"
#include "gpu/resources.hpp"
#include "renderers/gpu_scene.hpp"
#include "spirv/instrument.hpp"
#include "renderers/techniques/lod.hpp"
#include "renderers/pass_counters.hpp"
#include "renderers/renderer.hpp"
#include "renderers/techniques/shadows.hpp"
#include "renderers/techniques/tbn.hpp"
#include "shared.h"

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
  VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;  // the image's (MSAA targets)
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
  nlohmann::json pipelineStatistics() const override;
  SetupTimes setupTimes() const override { return setupTimes_; }
  std::vector<std::string> passNames() const override;
  uint32_t maxPipelineSetCount() const override { return maxLayoutSets_; }
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
    // Per instrumented shader: its invocation counter slot and its static
    // arithmetic per invocation (PassResult::arithmeticOps).
    // A shader whose executed arithmetic was counted (accumulate mode) has
    // its arithmetic slot with 1: the counter is the operations themselves.
    std::vector<std::pair<uint32_t, uint64_t>> arithmetic;
    bool arithmeticCounted = false;  // some shader's arithmetic is counted, not estimated
    std::string depthWrite;     // resource whose depth/stencil the pass writes ("" none)
    // Tile-memory model: resources whose traffic in this pass a tile-based GPU
    // keeps on chip (DONT_CARE attachments, input attachments of the render
    // pass); their lines get Access::onChip (renderers/techniques/tile_memory.hpp).
    std::set<std::string> onChip;
    uint64_t indicesDrawn = 0;  // this frame, by drawScene
    std::vector<std::pair<uint32_t, uint32_t>> indexRanges;  // (first index, count) drawn this frame
    bool indexFetches = false;  // derive "indices" reads from indicesDrawn
    std::vector<uint32_t> drawsRecorded;  // scene draws drawn this frame (options_.draws), in order
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
  // `samples` > 1: a multisampled target (RendererOptions::msaa).
  const gpu::Image* createTarget(const std::string& name, VkFormat format, VkImageUsageFlags usage,
                                 ResourceKind kind, uint32_t samples = 1);
  // A transient colour attachment (renderers/techniques/tile_memory.hpp): lazily
  // allocated memory where the device offers it; ResourceInfo::memory says.
  const gpu::Image* createTransientTarget(const std::string& name, VkFormat format, VkImageUsageFlags usage);
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
  // empty), empty up to the counter set (instrumented; uninstrumented
  // layouts end at the last set the pass's shaders use, 3 at most, and bind
  // no counter set); push constants DrawPush.
  VkPipelineLayout pipelineLayout(VkDescriptorSetLayout material, VkDescriptorSetLayout passInput);
  VkPipeline pipeline(const gpu::GraphicsPipelineDesc& desc);
  // One descriptor per binding, or counts[i] where given (arrays).
  VkDescriptorSetLayout setLayout(const std::vector<VkDescriptorType>& bindings,
                                  const std::vector<uint32_t>& counts = {});
  VkDescriptorSet allocateSet(VkDescriptorSetLayout layout);
  void writeImage(VkDescriptorSet set, uint32_t binding, VkImageView view, VkSampler sampler,
                  VkImageLayout layout);

  // Vertex buffer binding 0 (shaders::Vertex) with the four attributes.
  // tangent_frame = quaternion: the packed 24-byte vertex (renderers/techniques/tbn.hpp),
  // position, uv and the frame as R32_UINT at kAttribNormal.
  // glTF scenes: vertex buffer 1 (shaders::VertexAttributes) where a mesh has
  // colours or a second uv set, and the cull mode as dynamic state where a
  // material is single-sided.
  void meshVertexInput(gpu::GraphicsPipelineDesc& desc) const;
  // Frame and geometry sets, `material`/`passInput` where given, counters.
  // `geometry` replaces the scene's geometry set where given.
  void bindSets(VkCommandBuffer cmd, VkPipelineLayout layout, VkDescriptorSet material,
                VkDescriptorSet passInput, VkDescriptorSet geometry = VK_NULL_HANDLE);
  void bindSetsAt(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipelineLayout layout, VkDescriptorSet material,
                  VkDescriptorSet passInput, VkDescriptorSet geometry);
  // A geometry set (draws, materials, vertices, indices, vertex attributes,
  // material extras) with other materials buffers.
  VkDescriptorSet geometrySetWith(const gpu::Buffer& materials, const gpu::Buffer& materialExtras);
  // The draws of `subset` (alpha mode), push constants and (when
  // materialSets) the draw's material set; with LOD on, each draw's level
  // chosen for this frame; the cull mode per draw where the scene has
  // single-sided materials; Blend back to front from the frame's eye.
  void drawScene(VkCommandBuffer cmd, uint32_t passIndex, VkPipelineLayout layout, bool materialSets,
                 DrawSubset subset = DrawSubset::Opaque);
  void beginRenderPass(VkCommandBuffer cmd, uint32_t passIndex, VkRenderPass renderPass, VkFramebuffer fb,
                       const std::vector<VkClearValue>& clears);
  void endRenderPass(VkCommandBuffer cmd, uint32_t passIndex);
  // Inside one render pass: ends pass `fromPass`'s statistics query, moves to
  // the next subpass and begins `toPass`'s (queries may not span subpasses).
  // Timestamps stay around whole records: the pass that records the render
  // pass carries the time of all its subpasses.
  void nextSubpass(VkCommandBuffer cmd, uint32_t fromPass, uint32_t toPass);
  void drawFullScreen(VkCommandBuffer cmd) { vkCmdDraw(cmd, 3, 1, 0, 0); }

  // alphaMode MASK (glTF scenes): the masked twin of a geometry pipeline,
  // `desc` with `vertex` and `fragment` compiled again with TALLY_ALPHA_TEST
  // (no early fragment tests; discard below the cutoff) and the material set
  // bound per draw for the test. The returned recorder binds it and draws the
  // scene's masked draws; it is empty when the scene has none. Record it
  // right after the pass's opaque drawScene, inside the same render pass.
  using DrawRecorder = std::function<void(VkCommandBuffer)>;
  Result<DrawRecorder> maskedDraws(uint32_t passIndex, gpu::GraphicsPipelineDesc desc, const std::string& vertex,
                                   const std::string& fragment, const std::vector<std::string>& defines = {});
  // Why this configuration cannot draw the scene's glTF features ("" when
  // it can; scene_limits.hpp): checked before setupPasses().
  std::string featureRefusal() const;

  // Compute passes. A pass that dispatches compiles its .comp.glsl through
  // computePipeline() (instrumented like every shader; the sites go to the
  // pass, its invocations to PassResult::computeInvocations) with a layout
  // from computePipelineLayout() (sets as pipelineLayout(), push constants
  // for the compute stage), binds with bindComputeSets() and brackets its
  // dispatches with beginComputePass()/endComputePass() (the pass's pipeline
  // statistics). Storage images are written in VK_IMAGE_LAYOUT_GENERAL; the
  // pass moves them there and back itself (gpu::transitionImage).
  VkPipelineLayout computePipelineLayout(VkDescriptorSetLayout material, VkDescriptorSetLayout passInput);
  Result<VkPipeline> computePipeline(uint32_t passIndex, const std::string& file, VkPipelineLayout layout,
                                     const std::vector<std::string>& defines = {});
  void bindComputeSets(VkCommandBuffer cmd, VkPipelineLayout layout, VkDescriptorSet material,
                       VkDescriptorSet passInput, VkDescriptorSet geometry = VK_NULL_HANDLE);
  void beginComputePass(VkCommandBuffer cmd, uint32_t passIndex);
  void endComputePass(VkCommandBuffer cmd, uint32_t passIndex);
  // A VK_DESCRIPTOR_TYPE_STORAGE_IMAGE descriptor in layout GENERAL.
  void writeStorageImage(VkDescriptorSet set, uint32_t binding, VkImageView view);
  // Extra usage for the "hdr" target: VK_IMAGE_USAGE_STORAGE_BIT where a
  // compute pass writes it. Only such renderers ask: storage usage can cost
  // the target its compression on some GPUs.
  virtual VkImageUsageFlags hdrExtraUsage() const { return 0; }
  // The full-screen shading pass into "hdr" (deferred lighting, visibility
  // buffer shading): `fragment` with `defines` over fullscreen.vert, sets
  // material/input/geometry bound as given. At 1 sample it shades only the
  // pixels the scene covered (depth test against "depth", read only); with
  // msaa it clears the 1-sample "depth" and resolves per sample
  // (techniques/msaa.hpp). addComputeShading is its compute twin.
  Result<bool> addFullScreenShading(uint32_t passIndex, const std::string& fragment, VkDescriptorSetLayout material,
                                    VkDescriptorSet materialSet, VkDescriptorSetLayout inputLayout,
                                    VkDescriptorSet input, VkDescriptorSet geometry,
                                    std::vector<std::string> defines = {});
  // Shading in compute (compute_shading.cpp; RendererOptions::computeShading):
  // pass `passIndex` dispatches `file` in kComputeShadingGroup^2 workgroups
  // over the extent with sets as bindComputeSets(material, input, geometry);
  // `inputLayout` is computeShadingInputLayout()'s, and "hdr" is written here
  // at kBindingHdrImage (moved UNDEFINED -> GENERAL before the dispatch and to
  // SHADER_READ_ONLY_OPTIMAL after it). Renderers using it return
  // computeShadingUsage() from hdrExtraUsage() and computeShadingNotes() in notes().
  static constexpr uint32_t kComputeShadingGroup = 8;
  // `inputs` (at most kBindingHdrImage) combined image samplers at bindings
  // 0.., and the storage image at shaders::kBindingHdrImage; compute stage only.
  VkDescriptorSetLayout computeShadingInputLayout(uint32_t inputs);
  Result<bool> addComputeShading(uint32_t passIndex, const std::string& file, VkDescriptorSetLayout material,
                                 VkDescriptorSet materialSet, VkDescriptorSetLayout inputLayout,
                                 VkDescriptorSet input, VkDescriptorSet geometry,
                                 const std::vector<std::string>& defines = {});
  VkImageUsageFlags computeShadingUsage() const;
  void computeShadingNotes(nlohmann::json& notes) const;
  // False for a compute workload that fills "hdr" everywhere and has no
  // depth/stencil: the base then adds no skybox pass.
  virtual bool drawsSky() const { return true; }

  // Geometry passes: depth LESS (written when writeDepth), stencil set to
  // kStencilGeometry on every fragment that passes.
  static void geometryState(gpu::GraphicsPipelineDesc& desc, bool writeDepth);
  // A position-only "zprepass" pass clearing and writing "depth"
  // (zprepass.vert; zprepass.frag in instrumented runs, so that its depth
  // writes are counted). The next geometry pass loads depth and tests EQUAL.
  Result<bool> addDepthPrepass();
  // A depth-only pipeline description for pass `passIndex`: `vertex` (a
  // position-only vertex shader), zprepass.frag in instrumented runs (its
  // counted invocations give the pass's depth writes), the mesh vertex input,
  // no colour attachment; the caller sets the depth state.
  Result<gpu::GraphicsPipelineDesc> depthOnlyPipeline(uint32_t passIndex, const std::string& vertex,
                                                      VkRenderPass renderPass);
  // Full-screen shading passes: only pixels the geometry passes marked with
  // kStencilGeometry are shaded (sky pixels are masked out).
  static void geometryPixelsOnly(gpu::GraphicsPipelineDesc& desc);
  static VkClearValue depthClear();  // depth 1 (far), stencil 0
  // After the base has attributed a frame: renderer-specific derived lines.
  virtual FrameResult finishFrame(FrameResult frame) { return frame; }

  // The index and draws buffers the geometry set and drawScene bind: the
  // scene's, or with LOD on the LOD index buffer and the per-frame draws.
  const gpu::Buffer& indexBuffer() const;
  const gpu::Buffer& drawsBuffer() const;
  std::unique_ptr<LodSelection> lod_;  // with options_.lodThresholdPx > 0
  // The vertex buffer the geometry set and drawScene bind: the scene's, or
  // with tangent_frame = quaternion the packed one (renderers/techniques/tbn.hpp).
  const gpu::Buffer& vertexBuffer() const;
  std::unique_ptr<PackedVertexBuffer> packedVertices_;

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
  shaders::Camera frameCamera_ = {};          // the camera uniform of the last renderFrame()
  std::vector<ResourceInfo> resources_;

 private:
  // setup's steps (renderer_base.cpp).
  void createSetLayouts(const GpuScene& scene, const RendererOptions& options);
  Result<bool> createFrameData(gpu::Context& ctx, const GpuScene& scene);
  void writeSceneSets(gpu::Context& ctx, const GpuScene& scene);
  void addSharedResources(const GpuScene& scene);
  void createCountersAndQueries(gpu::Context& ctx);
  void setupTonemapAndSkybox();
  // alphaMode BLEND (glTF scenes): the "transparent" pass after the skybox,
  // forward-shaded and tonemapped per fragment, blended into "final" back to
  // front with depth tested against the opaque depth and not written.
  void setupTransparentPass();
  bool hasTransparentPass() const;
  // Sets as pipelineLayout() describes; push constants DrawPush for `pushStages`.
  VkPipelineLayout makePipelineLayout(VkDescriptorSetLayout material, VkDescriptorSetLayout passInput,
                                      VkShaderStageFlags pushStages);
  // Bloom's passes before tonemap (options_.bloom; none when off) and its
  // targets: "bloom_bright", "bloom_h" (the two-pass blurs), "bloom".
  void setupBloom();
  std::vector<std::string> bloomPassNames() const;
  // Shadow mapping (shadows.cpp; none with shadows off): the "shadow" pass
  // first, "shadow_map" and the sun's uniform bound in set 0, the defines
  // every shader gets and the bindings every pass has.
  Result<bool> setupShadows();
  void destroyShadows();
  std::vector<std::string> shadowDefines() const;
  void shadowBindings(PassBindings& bindings) const;
  ShadowState shadow_;
  void recordAll(VkCommandBuffer cmd);
  // Each pass's VK_EXT_debug_utils label (gpu/debug_names.hpp): recordAll
  // opens and closes one around every pass's record; nextSubpass moves to the
  // next pass's label inside a render pass of several subpasses.
  void beginPassLabel(VkCommandBuffer cmd, uint32_t passIndex);
  void endPassLabel(VkCommandBuffer cmd);
  bool labelOpen_ = false;
  std::set<uint32_t> subpassLabelled_;  // passes labelled by nextSubpass in this recording

  // Footprint (options_.footprintBlockBytes > 0; base_footprint.cpp). The
  // first frame records once without submitting to learn which descriptor
  // sets each pass binds (a bank of the table per pass and combination of
  // sets); the table is then built from the sites and the descriptors
  // written, and every bind of the counter set selects its bank.
  bool footprintOn() const { return options_.instrumented && options_.footprintBlockBytes != 0; }
  void discoverFootprint();
  uint32_t footprintBank(VkPipelineBindPoint point);
  void fillFootprintBank(uint32_t bank, uint32_t passIndex, VkPipelineBindPoint point);
  void bindCounterSet(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipelineLayout layout);
  // The derived "indices" line's footprint: the blocks of the index ranges drawn.
  void indexFootprint(const Pass& pass, std::vector<Access>& accesses) const;
  void attributeFootprint(uint32_t passIndex, std::vector<Access>& accesses, const std::vector<uint32_t>& bitmap) const;
  gpu::FootprintTable footprint_;
  bool footprintReady_ = false, footprintDiscovering_ = false;
  uint32_t recordingPass_ = 0;
  std::array<std::array<VkDescriptorSet, 8>, 2> boundSets_{};  // graphics, compute: the sets bound now
  std::map<std::pair<uint32_t, std::array<VkDescriptorSet, 8>>, uint32_t> banks_;
  std::map<std::string, std::set<std::string>> footprintRegions_;  // line key -> its regions
  std::set<std::string> unmeasuredLines_;                            // a site of the line is not marked
  struct VertexInput {
    uint32_t binding = 0, offset = 0, stride = 0;
  };
  std::map<uint32_t, std::map<uint32_t, VertexInput>> vertexInputs_;  // pass -> location -> input

  std::vector<Pass> passes_;
  uint32_t counterSet_ = 7;
  uint32_t maxLayoutSets_ = 0;  // the most descriptor sets of a pipeline layout made since setup
  uint32_t slotCount_ = 0;                       // counter slots reserved, copies included
  std::vector<spirv::CopyLayout> copyLayouts_;   // striped modules, folded after readback
  // Counts per draw (options_.draws; base_draw_counts.cpp): the counter
  // buffer holds regionCount_ regions of regionSlots_ slots, each a whole
  // copy of the slot space bound with a dynamic offset: region 0 for work
  // outside draws, 1 + d for scene draw d below options_.maxCountedDraws,
  // and one more shared by the draws beyond.
  bool countsDraws() const { return options_.instrumented && options_.draws; }
  uint32_t drawRegion(uint32_t draw) const;
  void sizeCounterRegions();
  // Reads the counters back and settles them: with draws, each region
  // settled into `regions`; the result is the whole frame's (their sum).
  std::vector<uint64_t> readCounters(std::vector<std::vector<uint64_t>>& regions);
  // PassResult::draws, drawsRest and materials of pass `passIndex`.
  void attributeDraws(uint32_t passIndex, PassResult& result, const std::vector<std::vector<uint64_t>>& regions) const;
  void splitMaterialMaps(uint32_t passIndex, PassResult& result, const PassCounts& counts) const;
  uint32_t countedDraws_ = 0;  // draws with a region of their own: maxCountedDraws, less where memory bounds it
  uint32_t regionSlots_ = 0, regionCount_ = 1, counterRegion_ = 0;
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
  nlohmann::json tileMemoryExtras_;          // frameExtras()["tile_memory"], of the last frame
  std::vector<VkDescriptorSetLayout> ownedSetLayouts_;
  std::vector<VkPipelineLayout> pipelineLayouts_;
  std::vector<VkPipeline> pipelines_;
  std::vector<VkShaderModule> modules_;
  SetupTimes setupTimes_;
  std::map<VkShaderModule, uint32_t> modulePass_;                // the pass each module was compiled for
  std::vector<std::pair<uint32_t, VkPipeline>> passPipelines_;  // (pass, pipeline), for pipelineStatistics
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
  bool dynamicCull_ = false;  // the scene has single-sided materials: cull mode per draw
  void meshVertexStreams(gpu::GraphicsPipelineDesc& desc) const;  // vertex buffer 0

 protected:
  // Render passes created by derived classes are destroyed with the renderer.
  VkRenderPass ownRenderPass(VkRenderPass rp) {
    renderPasses_.push_back(rp);
    return rp;
  }
};

}  // namespace tally::renderers

// The two analytically known passes the exactness tests run:
//  - FragmentPass: a full-screen triangle into an RGBA8 target, fragment
//    shader with K = 5 texture reads from 3 sampler2D bindings;
//  - ComputePass: 8x8 workgroups over ceil(W/8) x ceil(H/8), 3 texture reads,
//    1 buffer read, 1 buffer write, 1 image write per in-bounds invocation.
// Each can run uninstrumented or instrumented with any mode; a run returns the
// counters, the sites, the pipeline statistics, the pass times and the output.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gpu/context.hpp"
#include "gpu/pipelines.hpp"
#include "gpu/queries.hpp"
#include "gpu/resources.hpp"
#include "gpu/shaders.hpp"

namespace tally::test {

constexpr uint32_t kFragmentReads = 5;         // texture() calls per pixel in five_reads.frag.glsl
constexpr uint32_t kFragmentTextures = 3;      // sampler2D bindings they read
constexpr uint32_t kComputeTextureReads = 3;   // texelFetch x2 + imageLoad in mixed_reads.comp.glsl
constexpr uint32_t kComputeWorkgroupSize = 8;  // local_size_x = local_size_y

struct RunOptions {
  std::optional<spirv::Mode> mode;  // nullopt: uninstrumented
  spirv::CounterWidth width = spirv::CounterWidth::Int64;
  uint32_t submissions = 1;  // each zeroes the counters; counters and statistics are from the last
  // Where each submission starts the counters instead of zero: slot i starts
  // at initialCounters[i] (slots past the end at 0). Lets a test put a counter
  // next to 2^32 without running 4 billion atomics first.
  std::vector<uint64_t> initialCounters;
  // accumulate: copies of each compute counter (0: the device default).
  uint32_t computeCopies = 0;
  // accumulate: derive the sites that run once in every invocation (InstrumentOptions::deriveOnceSites).
  bool deriveOnceSites = true;
  // Counter slots per access site (InstrumentOptions::perSite).
  bool perSite = false;
};

struct PassRun {
  std::vector<uint64_t> counters;  // the whole counter buffer, striped copies folded into their slots
  uint32_t copiesWritten = 0;      // striped modules: the most copies of one that received counts
  std::vector<spirv::Site> sites;  // of every instrumented module
  std::vector<std::string> notes;
  gpu::PipelineStatistics statistics;
  std::vector<double> timesMs;  // one per submission
  double medianMs = 0;          // of the submissions after the first (warm-up), or the only one
  // Host wall-clock of each submission (record, submit, wait on the fence):
  // a cross-check where device timestamps are coarse (CPU drivers).
  std::vector<double> wallMs;
  double medianWallMs = 0;
  std::vector<uint8_t> output;  // colour target (fragment) or output buffer + output image (compute)
};

class FragmentPass {
 public:
  // `target` overrides gpu::glslTarget(ctx) for both stages. `fragment` is a
  // shader of shaders/ with five_reads' bindings (3 sampler2D, one output),
  // `vertex` one that draws fullscreen.vert's triangle (it may read them too).
  FragmentPass(const gpu::Context& ctx, uint32_t width, uint32_t height,
               std::optional<glsl::Target> target = std::nullopt,
               const std::string& fragment = "five_reads.frag.glsl",
               const std::string& vertex = "fullscreen.vert.glsl");
  ~FragmentPass();
  FragmentPass(const FragmentPass&) = delete;
  FragmentPass& operator=(const FragmentPass&) = delete;

  // Errors (compile, instrument) come back as Error; Vulkan failures throw VulkanError.
  Result<PassRun> run(const RunOptions& options);

 private:
  const gpu::Context& ctx_;
  uint32_t width_, height_;
  std::vector<uint32_t> vertexWords_, fragmentWords_;
  std::string compileError_;
  gpu::Image textures_[kFragmentTextures];
  gpu::Image target_;
  VkSampler sampler_ = VK_NULL_HANDLE;
  VkRenderPass renderPass_ = VK_NULL_HANDLE;
  VkFramebuffer framebuffer_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout sceneLayout_ = VK_NULL_HANDLE, emptyLayout_ = VK_NULL_HANDLE,
                        counterLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout pipelineLayout_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet sceneSet_ = VK_NULL_HANDLE;
  uint32_t counterSet_ = 0;
};

// Binding 5 of ComputePass's set: an array of this many storage buffers, each
// the input buffer (more than the 16 elements accumulate keeps in registers).
constexpr uint32_t kComputeBufferArray = 20;

class ComputePass {
 public:
  // `shader`: a compute shader of shaders/ with mixed_reads' bindings (and binding 5).
  ComputePass(const gpu::Context& ctx, uint32_t width, uint32_t height,
              const std::string& shader = "mixed_reads.comp.glsl");
  ~ComputePass();
  ComputePass(const ComputePass&) = delete;
  ComputePass& operator=(const ComputePass&) = delete;

  Result<PassRun> run(const RunOptions& options);
  uint32_t groupsX() const { return (width_ + kComputeWorkgroupSize - 1) / kComputeWorkgroupSize; }
  uint32_t groupsY() const { return (height_ + kComputeWorkgroupSize - 1) / kComputeWorkgroupSize; }

 private:
  const gpu::Context& ctx_;
  uint32_t width_, height_;
  std::vector<uint32_t> words_;
  std::string compileError_;
  gpu::Image source_, inputImage_, outputImage_;
  gpu::Buffer inputBuffer_, outputBuffer_;
  VkSampler sampler_ = VK_NULL_HANDLE;
  VkDescriptorSetLayout sceneLayout_ = VK_NULL_HANDLE, emptyLayout_ = VK_NULL_HANDLE,
                        counterLayout_ = VK_NULL_HANDLE;
  VkPipelineLayout pipelineLayout_ = VK_NULL_HANDLE;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet sceneSet_ = VK_NULL_HANDLE;
  uint32_t counterSet_ = 0;
};

}  // namespace tally::test

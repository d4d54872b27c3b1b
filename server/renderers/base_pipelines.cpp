// RendererBase: shader modules (instrumented per mode), pipeline layouts and
// the graphics and compute pipelines every renderer builds on.
#include "renderers/renderer_base.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>

#include "common/paths.hpp"
#include "gpu/shaders.hpp"
#include "gpu/vk_check.hpp"
#include "shared.h"

namespace tally::renderers {

Result<std::string> shaderDirectory() {
  if (const char* dir = std::getenv("TALLY_SHADER_DIR"); dir != nullptr && *dir) return std::string(dir);
  auto data = dataDirectory();
  if (!data) return makeError(data.error());
  return (*data / "shaders").string();
}

Result<gpu::GraphicsPipelineDesc> RendererBase::shaderPipeline(uint32_t passIndex, const std::string& vertex,
                                                               const std::string& fragment, VkPipelineLayout layout,
                                                               VkRenderPass renderPass,
                                                               const std::vector<std::string>& fragmentDefines) {
  auto vs = shader(passIndex, vertex);
  if (!vs) return makeError(vs.error());
  auto fs = shader(passIndex, fragment, fragmentDefines);
  if (!fs) return makeError(fs.error());
  gpu::GraphicsPipelineDesc desc;
  desc.vertex = *vs;
  desc.fragment = *fs;
  desc.layout = layout;
  desc.renderPass = renderPass;
  return desc;
}

Result<VkShaderModule> RendererBase::shader(uint32_t passIndex, const std::string& file,
                                            const std::vector<std::string>& defines) {
  const auto started = std::chrono::steady_clock::now();
  struct Timed {
    std::chrono::steady_clock::time_point started;
    double& into;
    ~Timed() { into += std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(); }
  } timed{started, setupTimes_.shaderSeconds};
  auto dir = shaderDirectory();
  if (!dir) return makeError(dir.error());
  auto source = gpu::loadShaderSource(*ctx_, *dir, file);
  if (!source) return makeError(source.error());
  std::vector<std::string> allDefines = defines;
  if (packedVertices_) allDefines.push_back("TALLY_TBN_QUATERNION");  // shaders/tbn.h; none: float as it was
  for (auto& d : scene_->featureDefines()) allDefines.push_back(std::move(d));  // glTF features; none for procedural scenes
  for (auto& d : shadowDefines()) allDefines.push_back(std::move(d));    // shaders/shadow.h; none with shadows off
  if (!allDefines.empty()) {
    size_t eol = source->source.find('\n');
    std::string text;
    for (const auto& d : allDefines) text += "#define " + d + "\n";
    text += "#line 2\n";  // the file's own line numbers after them (messages, OpLine)
    source->source.insert(eol == std::string::npos ? source->source.size() : eol + 1, text);
  }
  std::vector<uint32_t> words;
  if (options_.instrumented) {
    auto instrumentOptions = gpu::instrumentOptionsFor(*ctx_, options_.counting, slotCount_);
    instrumentOptions.footprintBlockBytes = options_.footprintBlockBytes;
    // Executed arithmetic for the roofline (accumulate mode) where the
    // capture asks about memory (footprint on): it costs a register add per
    // block, 1.10-1.14x per frame on Sponza against 1.02-1.03x without
    // (docs/accuracy.md); elsewhere the arithmetic is the static estimate.
    instrumentOptions.countArithmetic = options_.footprintBlockBytes != 0;
    // Bytes per source line: slots per site, and OpLine in the module.
    instrumentOptions.perSite = options_.sites;
    source->compile.debugInfo = options_.sites;
    if (auto why = gpu::unsupportedReason(*ctx_, source->stage, instrumentOptions); !why.empty()) {
      return makeError(file + ": " + why);
    }
    auto compiled = gpu::compileAndInstrument(*ctx_, *source, instrumentOptions);
    if (!compiled) return makeError(file + ": " + compiled.error());
    counterSet_ = instrumentOptions.set;
    slotCount_ += compiled->result.layout().reserved();
    if (compiled->result.layout().needsSettling()) copyLayouts_.push_back(compiled->result.layout());
    auto& sites = passes_[passIndex].sites;
    const size_t first = sites.size();
    sites.insert(sites.end(), compiled->result.sites.begin(), compiled->result.sites.end());
    // Lines in included files come with the includer's full path: name them as the shader folder does.
    for (size_t k = first; k < sites.size(); ++k) {
      sites[k].shader = file;
      if (sites[k].file.rfind(*dir + "/", 0) == 0) sites[k].file.erase(0, dir->size() + 1);
    }
    if (compiled->result.arithmeticSlot >= 0) {  // the roofline's arithmetic, counted as executed
      passes_[passIndex].arithmetic.emplace_back(uint32_t(compiled->result.arithmeticSlot), 1);
      passes_[passIndex].arithmeticCounted = true;
    }
    for (const auto& site : compiled->result.sites) {  // else the static estimate per invocation
      if (site.kind != spirv::SiteKind::Invocation || compiled->result.arithmeticSlot >= 0) continue;
      for (const auto& e : compiled->result.arithmetic) {
        if (e.entryPoint == site.entryPoint) passes_[passIndex].arithmetic.emplace_back(site.slot, e.ops.total());
      }
    }
    words = std::move(compiled->words);
  } else {
    auto compiled = gpu::compileShader(*source);
    if (!compiled) return makeError(file + ": " + compiled.error());
    words = std::move(compiled->words);
  }
  modules_.push_back(gpu::createShaderModule(*ctx_, words));
  modulePass_[modules_.back()] = passIndex;
  gpu::nameObject(*ctx_, VK_OBJECT_TYPE_SHADER_MODULE, gpu::handleValue(modules_.back()), file);
  return modules_.back();
}

VkPipelineLayout RendererBase::pipelineLayout(VkDescriptorSetLayout material,
                                              VkDescriptorSetLayout passInput) {
  return makePipelineLayout(material, passInput, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
}

VkPipelineLayout RendererBase::makePipelineLayout(VkDescriptorSetLayout material, VkDescriptorSetLayout passInput,
                                                  VkShaderStageFlags pushStages) {
  const uint32_t count = options_.instrumented ? counterSet_ + 1 : shaders::kSetPassInput + 1;
  std::vector<VkDescriptorSetLayout> sets(count, emptyLayout_);
  sets[shaders::kSetFrame] = frameLayout_;
  sets[shaders::kSetGeometry] = geometryLayout_;
  if (material != VK_NULL_HANDLE) sets[shaders::kSetMaterial] = material;
  if (passInput != VK_NULL_HANDLE) sets[shaders::kSetPassInput] = passInput;
  if (options_.instrumented) {
    sets[counterSet_] = counterLayout_;
  } else {
    // An ordinary application's layout: no counter set, and no empty sets
    // after the last one the shaders use (a set they use is never empty).
    while (sets.size() > 1 && sets.back() == emptyLayout_) sets.pop_back();
  }
  maxLayoutSets_ = std::max(maxLayoutSets_, uint32_t(sets.size()));
  pipelineLayouts_.push_back(gpu::createPipelineLayout(*ctx_, sets, sizeof(shaders::DrawPush), pushStages));
  return pipelineLayouts_.back();
}

VkPipeline RendererBase::pipeline(const gpu::GraphicsPipelineDesc& desc) {
  const auto started = std::chrono::steady_clock::now();
  pipelines_.push_back(gpu::createGraphicsPipeline(*ctx_, desc));
  setupTimes_.pipelineSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  for (VkShaderModule m : {desc.fragment, desc.vertex}) {
    if (auto it = modulePass_.find(m); it != modulePass_.end()) {
      passPipelines_.emplace_back(it->second, pipelines_.back());
      gpu::nameObject(*ctx_, VK_OBJECT_TYPE_PIPELINE, gpu::handleValue(pipelines_.back()), passes_[it->second].name);
      break;
    }
  }
  // Where each vertex attribute comes from (footprint of vertex inputs).
  if (auto it = modulePass_.find(desc.vertex); it != modulePass_.end()) {
    for (const auto& a : desc.vertexAttributes) {
      for (const auto& b : desc.vertexBindings) {
        if (b.binding == a.binding) vertexInputs_[it->second][a.location] = {a.binding, a.offset, b.stride};
      }
    }
  }
  return pipelines_.back();
}

nlohmann::json RendererBase::pipelineStatistics() const {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [passIndex, pipeline] : passPipelines_) {
    for (const auto& e : gpu::executableStatistics(*ctx_, pipeline)) {
      out.push_back({{"pass", passes_[passIndex].name},
                     {"stages", e.stages},
                     {"executable", e.name},
                     {"statistics", e.values}});
    }
  }
  return out;
}

Result<gpu::GraphicsPipelineDesc> RendererBase::depthOnlyPipeline(uint32_t passIndex, const std::string& vertex,
                                                                  VkRenderPass renderPass) {
  auto vs = shader(passIndex, vertex);
  if (!vs) return makeError(vs.error());
  gpu::GraphicsPipelineDesc desc;
  desc.vertex = *vs;
  if (options_.instrumented) {
    auto fs = shader(passIndex, "zprepass.frag.glsl");
    if (!fs) return makeError(fs.error());
    desc.fragment = *fs;
  }
  desc.layout = pipelineLayout(VK_NULL_HANDLE, VK_NULL_HANDLE);
  desc.renderPass = renderPass;
  desc.colorAttachmentCount = 0;
  meshVertexInput(desc);
  return desc;
}

void RendererBase::geometryState(gpu::GraphicsPipelineDesc& desc, bool writeDepth) {
  desc.depthTest = true;
  desc.depthWrite = writeDepth;
  desc.depthCompare = VK_COMPARE_OP_LESS;  // depth [0, 1], far = 1 (shared.h)
  desc.stencilTest = true;
  desc.stencilCompare = VK_COMPARE_OP_ALWAYS;
  desc.stencilPassOp = VK_STENCIL_OP_REPLACE;
  desc.stencilReference = kStencilGeometry;
  desc.stencilWriteMask = 0xff;
}

VkClearValue RendererBase::depthClear() {
  VkClearValue v = {};
  v.depthStencil = {1.0f, 0};
  return v;
}

void RendererBase::geometryPixelsOnly(gpu::GraphicsPipelineDesc& desc) {
  desc.stencilTest = true;
  desc.stencilCompare = VK_COMPARE_OP_EQUAL;
  desc.stencilReference = kStencilGeometry;
}

void RendererBase::meshVertexInput(gpu::GraphicsPipelineDesc& desc) const {
  desc.dynamicCullMode = dynamicCull_;
  meshVertexStreams(desc);
  const auto& f = scene_->features();
  if (f.vertexColors || f.uv1) {  // glTF's optional streams: vertex buffer 1
    desc.vertexBindings.push_back({1, sizeof(shaders::VertexAttributes), VK_VERTEX_INPUT_RATE_VERTEX});
    if (f.vertexColors) desc.vertexAttributes.push_back({shaders::kAttribColor, 1, VK_FORMAT_R16G16B16A16_UNORM, 0});
    if (f.uv1) desc.vertexAttributes.push_back({shaders::kAttribUv1, 1, VK_FORMAT_R32G32_SFLOAT, 8});
  }
}

void RendererBase::meshVertexStreams(gpu::GraphicsPipelineDesc& desc) const {
  if (packedVertices_) {  // renderers/techniques/tbn.hpp: PackedVertex
    desc.vertexBindings = {{0, sizeof(PackedVertex), VK_VERTEX_INPUT_RATE_VERTEX}};
    desc.vertexAttributes = {
        {shaders::kAttribPosition, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(PackedVertex, position)},
        {shaders::kAttribNormal, 0, VK_FORMAT_R32_UINT, offsetof(PackedVertex, tbn)},
        {shaders::kAttribUv, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(PackedVertex, uv)},
    };
    return;
  }
  desc.vertexBindings = {{0, sizeof(shaders::Vertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  desc.vertexAttributes = {
      {shaders::kAttribPosition, 0, VK_FORMAT_R32G32B32_SFLOAT, 0},
      {shaders::kAttribNormal, 0, VK_FORMAT_R32G32B32_SFLOAT, 12},
      {shaders::kAttribTangent, 0, VK_FORMAT_R32G32B32A32_SFLOAT, 24},
      {shaders::kAttribUv, 0, VK_FORMAT_R32G32_SFLOAT, 40},
  };
}

VkPipelineLayout RendererBase::computePipelineLayout(VkDescriptorSetLayout material,
                                                     VkDescriptorSetLayout passInput) {
  return makePipelineLayout(material, passInput, VK_SHADER_STAGE_COMPUTE_BIT);
}

Result<VkPipeline> RendererBase::computePipeline(uint32_t passIndex, const std::string& file,
                                                 VkPipelineLayout layout, const std::vector<std::string>& defines) {
  auto module = shader(passIndex, file, defines);
  if (!module) return makeError(module.error());
  const auto started = std::chrono::steady_clock::now();
  pipelines_.push_back(gpu::createComputePipeline(*ctx_, *module, layout));
  setupTimes_.pipelineSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  passPipelines_.emplace_back(passIndex, pipelines_.back());
  gpu::nameObject(*ctx_, VK_OBJECT_TYPE_PIPELINE, gpu::handleValue(pipelines_.back()), passes_[passIndex].name);
  return pipelines_.back();
}

}  // namespace tally::renderers

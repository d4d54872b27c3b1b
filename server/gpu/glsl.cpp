#include "gpu/glsl.hpp"

#include <fstream>
#include <mutex>
#include <sstream>

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>

namespace tally::glsl {
namespace {

EShLanguage toLanguage(spirv::Stage stage) {
  switch (stage) {
    case spirv::Stage::Vertex: return EShLangVertex;
    case spirv::Stage::TessControl: return EShLangTessControl;
    case spirv::Stage::TessEval: return EShLangTessEvaluation;
    case spirv::Stage::Geometry: return EShLangGeometry;
    case spirv::Stage::Fragment: return EShLangFragment;
    case spirv::Stage::Compute: return EShLangCompute;
    case spirv::Stage::Task: return EShLangTask;
    case spirv::Stage::Mesh: return EShLangMesh;
    case spirv::Stage::Other: break;
  }
  return EShLangCount;
}

// Resolves #include "name" against the including file's folder, then the
// configured folders. Keeps the text alive until glslang releases it.
class Includer : public glslang::TShader::Includer {
 public:
  explicit Includer(std::vector<std::string> dirs) : dirs_(std::move(dirs)) {}

  IncludeResult* includeLocal(const char* header, const char* includer, size_t) override {
    std::string from(includer);
    auto slash = from.find_last_of('/');
    std::vector<std::string> dirs;
    if (slash != std::string::npos) dirs.push_back(from.substr(0, slash));
    dirs.insert(dirs.end(), dirs_.begin(), dirs_.end());
    for (const auto& dir : dirs) {
      std::string path = dir + "/" + header;
      std::ifstream in(path, std::ios::binary);
      if (!in) continue;
      std::stringstream text;
      text << in.rdbuf();
      auto* owned = new std::string(text.str());
      return new IncludeResult(path, owned->data(), owned->size(), owned);
    }
    return nullptr;
  }
  IncludeResult* includeSystem(const char* header, const char* includer, size_t depth) override {
    return includeLocal(header, includer, depth);
  }
  void releaseInclude(IncludeResult* result) override {
    if (result == nullptr) return;
    delete static_cast<std::string*>(result->userData);
    delete result;
  }

 private:
  std::vector<std::string> dirs_;
};

void initializeOnce() {
  static std::once_flag once;
  std::call_once(once, [] { glslang::InitializeProcess(); });
}

}  // namespace

Result<std::vector<uint32_t>> compile(std::string_view source, spirv::Stage stage,
                                      const CompileOptions& options) {
  initializeOnce();
  EShLanguage language = toLanguage(stage);
  if (language == EShLangCount) return makeError(options.fileName + ": unsupported shader stage");

  glslang::EShTargetClientVersion client = glslang::EShTargetVulkan_1_3;
  glslang::EShTargetLanguageVersion spv = glslang::EShTargetSpv_1_6;
  switch (options.target) {
    case Target::Vulkan10: client = glslang::EShTargetVulkan_1_0; spv = glslang::EShTargetSpv_1_0; break;
    case Target::Vulkan11: client = glslang::EShTargetVulkan_1_1; spv = glslang::EShTargetSpv_1_3; break;
    case Target::Vulkan12: client = glslang::EShTargetVulkan_1_2; spv = glslang::EShTargetSpv_1_5; break;
    case Target::Vulkan13: break;
  }

  glslang::TShader shader(language);
  const char* text = source.data();
  int length = static_cast<int>(source.size());
  const char* name = options.fileName.c_str();
  shader.setStringsWithLengthsAndNames(&text, &length, &name, 1);
  shader.setEnvInput(glslang::EShSourceGlsl, language, glslang::EShClientVulkan, 100);
  shader.setEnvClient(glslang::EShClientVulkan, client);
  shader.setEnvTarget(glslang::EShTargetSpv, spv);

  // EShMsgDebugInfo gives OpLine/OpSource as `glslangValidator -g` does;
  // TShader::setDebugInfo would also ask for NonSemantic debug info, which
  // glslang 12 emits broken for nested scopes.
  auto messages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgVulkanRules |
                                           (options.debugInfo ? static_cast<int>(EShMsgDebugInfo) : 0));
  Includer includer(options.includeDirs);
  if (!shader.parse(GetDefaultResources(), 460, false, messages, includer)) {
    return makeError(options.fileName + ": " + shader.getInfoLog());
  }
  glslang::TProgram program;
  program.addShader(&shader);
  if (!program.link(messages)) return makeError(options.fileName + ": link: " + program.getInfoLog());

  std::vector<uint32_t> words;
  spv::SpvBuildLogger logger;
  glslang::SpvOptions spvOptions;
  spvOptions.generateDebugInfo = options.debugInfo;
  spvOptions.validate = false;  // the instrumentation validates with SPIRV-Tools
  glslang::GlslangToSpv(*program.getIntermediate(language), words, &logger, &spvOptions);
  std::string log = logger.getAllMessages();
  if (words.empty()) return makeError(options.fileName + ": SPIR-V generation failed: " + log);
  return words;
}

Result<spirv::Stage> stageFromFileName(std::string_view fileName) {
  std::string name(fileName);
  if (name.size() > 5 && name.ends_with(".glsl")) name.resize(name.size() - 5);
  auto dot = name.find_last_of('.');
  if (dot == std::string::npos) return makeError(std::string(fileName) + ": no stage in file name");
  std::string ext = name.substr(dot + 1);
  if (ext == "vert") return spirv::Stage::Vertex;
  if (ext == "tesc") return spirv::Stage::TessControl;
  if (ext == "tese") return spirv::Stage::TessEval;
  if (ext == "geom") return spirv::Stage::Geometry;
  if (ext == "frag") return spirv::Stage::Fragment;
  if (ext == "comp") return spirv::Stage::Compute;
  if (ext == "task") return spirv::Stage::Task;
  if (ext == "mesh") return spirv::Stage::Mesh;
  return makeError(std::string(fileName) + ": unknown stage '" + ext + "' (expected vert, frag, comp, ...)");
}

}  // namespace tally::glsl

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "commands/commands.hpp"
#include "gpu/glsl.hpp"
#include "renderers/renderer.hpp"
#include "spirv/instrument.hpp"

namespace tally::cli {

int runDemo(const DemoArgs& args) {
  auto mode = spirv::parseMode(args.mode);
  if (!mode) {
    std::cerr << "tallyd demo: --mode: " << mode.error() << "\n";
    return 1;
  }
  std::string shaderDir = args.shaderDir;
  if (shaderDir.empty()) {
    auto dir = renderers::shaderDirectory();
    if (!dir) {
      std::cerr << "tallyd demo: " << dir.error() << "\n";
      return 1;
    }
    shaderDir = *dir;
  }
  std::error_code ec;
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(shaderDir, ec)) {
    if (entry.path().extension() == ".glsl") files.push_back(entry.path());
  }
  if (ec) {
    std::cerr << "tallyd demo: " << shaderDir << ": " << ec.message() << "\n";
    return 1;
  }
  std::sort(files.begin(), files.end());
  int failures = 0;
  size_t totalSites = 0;
  for (const auto& path : files) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    auto stage = glsl::stageFromFileName(path.filename().string());
    if (!stage) continue;  // shared headers
    glsl::CompileOptions compileOptions;
    compileOptions.fileName = path.filename().string();
    compileOptions.debugInfo = true;
    compileOptions.includeDirs = {shaderDir};
    auto words = glsl::compile(text.str(), *stage, compileOptions);
    if (!words) {
      std::cerr << words.error() << "\n";
      ++failures;
      continue;
    }
    spirv::InstrumentOptions options;
    options.mode = *mode;
    auto result = spirv::instrument(*words, options);
    if (!result) {
      std::cerr << path.filename().string() << ": " << result.error() << "\n";
      ++failures;
      continue;
    }
    std::printf("\n%s  (%s, %zu sites, %u slots, %zu -> %zu words)\n", path.filename().c_str(),
                std::string(spirv::toString(*stage)).c_str(), result->sites.size(), result->slotCount,
                words->size(), result->words.size());
    std::printf("  %-5s %-16s %4s %4s %-7s %-18s %-26s %6s  %s\n", "slot", "kind", "set", "bind", "index",
                "resource", "element", "bytes", "line");
    for (const auto& s : result->sites) {
      std::string index = s.dynamicIndex ? "dyn[" + std::to_string(s.slotCount) + "]"
                                         : (s.index ? std::to_string(*s.index) : "-");
      if (s.location) index = "loc " + std::to_string(*s.location);
      std::string set = s.set >= 0 ? std::to_string(s.set) : "-";
      std::string binding = s.binding >= 0 ? std::to_string(s.binding) : "-";
      std::string line = s.line ? s.file + ":" + std::to_string(s.line) : "";
      std::printf("  %-5u %-16s %4s %4s %-7s %-18s %-26s %6u  %s\n", s.slot,
                  std::string(spirv::toString(s.kind)).c_str(), set.c_str(), binding.c_str(), index.c_str(),
                  s.resource.substr(0, 18).c_str(), s.elementType.substr(0, 26).c_str(), s.elementBytes,
                  line.c_str());
    }
    for (const auto& note : result->notes) std::printf("  note: %s\n", note.c_str());
    totalSites += result->sites.size();
  }
  std::printf("\n%zu shaders, %zu sites, %d failures (mode %s)\n", files.size(), totalSites, failures,
              spirv::toString(*mode).c_str());
  return failures == 0 ? 0 : 1;
}

}  // namespace tally::cli

#include "capture/shader_files.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "renderers/renderer.hpp"

namespace tally::capture {

using nlohmann::json;

// FNV-1a 64 of every shader source the renderers compile, so that a result
// names exactly which shaders produced it.
json shaderHashes() {
  json out = json::object();
  std::error_code ec;
  std::vector<std::filesystem::path> files;
  auto dir = renderers::shaderDirectory();
  if (!dir) return out;  // runCapture refused already
  for (const auto& entry : std::filesystem::directory_iterator(*dir, ec)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    std::ifstream in(file, std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    uint64_t h = 1469598103934665603ull;
    for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
    out[file.filename().string()] = hex;
  }
  return out;
}

// The text of the shader files whose lines the sites name (RendererOptions::sites), for a shader view.
json shaderSources(const std::set<std::string>& names) {
  json out = json::object();
  auto dir = renderers::shaderDirectory();
  if (!dir) return out;
  for (const auto& name : names) {
    // Only files inside the shader folder: names are relative to it.
    if (name.empty() || name.front() == '/' || name.find("..") != std::string::npos) continue;
    std::ifstream in(std::filesystem::path(*dir) / name, std::ios::binary);
    if (!in) continue;
    out[name] = std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  return out;
}

}  // namespace tally::capture

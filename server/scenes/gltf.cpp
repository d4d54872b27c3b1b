#include "scenes/gltf.hpp"
#include "scenes/gltf_check.hpp"
#include "scenes/gltf_loader.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <utility>

namespace tally::scenes {
namespace detail {

std::string quote(const std::string& s) { return "\"" + s + "\""; }

}  // namespace detail

namespace {

namespace fs = std::filesystem;
using detail::Loader;
using detail::quote;

// tinygltf calls this per image while parsing; we keep the encoded bytes and
// decode later on several threads (decoding is most of Sponza's load time).
bool keepEncoded(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                 const unsigned char* bytes, int size, void*) {
  image->image.assign(bytes, bytes + size);
  image->width = image->height = 0;  // not decoded yet
  return true;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n') c = ';';
  return s;
}

}  // namespace

Result<Scene> loadGltf(const std::string& path, const GltfOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return makeError(quote(path) + ": file not found");
  if (!fs::is_regular_file(path, ec)) return makeError(quote(path) + ": not a regular file");
  char magic[4] = {};
  {
    std::ifstream f(path, std::ios::binary);
    if (!f) return makeError(quote(path) + ": cannot open");
    f.read(magic, 4);
  }
  const bool binary = std::memcmp(magic, "glTF", 4) == 0;

  // Extensions, ranges and the node graph's instance counts, before tinygltf
  // reads any buffer or image (gltf_check.hpp).
  Result<GltfPrecheck> precheck = precheckGltf(path);
  if (!precheck) return makeError(quote(path) + ": " + precheck.error());

  Loader loader{options, {}, {}, {}, {}, -1};
  loader.scene.notes = precheck->notes;
  tinygltf::TinyGLTF gltf;
  gltf.SetImageLoader(keepEncoded, nullptr);
  std::string err, warn;
  bool ok = binary ? gltf.LoadBinaryFromFile(&loader.model, &err, &warn, path)
                   : gltf.LoadASCIIFromFile(&loader.model, &err, &warn, path);
  if (!ok) return makeError(quote(path) + ": not a valid glTF file: " + trimmed(err.empty() ? warn : err));
  if (!warn.empty()) loader.scene.notes.push_back("tinygltf: " + trimmed(warn));


  Result<bool> r = loader.loadMaterials();
  if (r) r = loader.loadNodes();
  if (r && !options.geometryOnly) r = loader.decodeTextures();
  if (!r) return makeError(quote(path) + ": " + r.error());
  if (loader.scene.meshes.empty()) return makeError(quote(path) + ": no triangles in the default scene");

  Scene& scene = loader.scene;
  scene.name = fs::path(path).stem().string();
  updateBounds(scene);
  scene.params = {{"gltf", path}};
  if (options.maxTextureSize > 0) scene.params["max_texture_size"] = options.maxTextureSize;
  return std::move(scene);
}

}  // namespace tally::scenes

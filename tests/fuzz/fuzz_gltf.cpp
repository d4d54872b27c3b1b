// glTF (.gltf JSON, or .glb with its binary chunk) into the pre-check and
// the loader: scenes::precheckGltf, then scenes::loadGltf when it passes,
// as the daemon does. Both take a path, so each input is written to a file
// in a private folder (a .glb when it starts with the "glTF" magic).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "scenes/gltf.hpp"
#include "scenes/gltf_check.hpp"

namespace {

std::filesystem::path folder;

void removeFolder() {
  std::error_code ec;
  std::filesystem::remove_all(folder, ec);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  char name[] = "/tmp/tally-fuzz-gltf-XXXXXX";
  if (!mkdtemp(name)) {
    std::perror("mkdtemp");
    std::abort();
  }
  folder = name;
  std::atexit(removeFolder);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  std::filesystem::path path = folder / (binary ? "scene.glb" : "scene.gltf");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  auto checked = tally::scenes::precheckGltf(path.string());
  if (checked.ok()) {
    // Small textures and one thread: the decoders are stb's, the loader's
    // own work is the accessors, nodes and materials.
    auto scene = tally::scenes::loadGltf(path.string(), {.maxTextureSize = 16, .threads = 1});
    (void)scene;
  }
  std::filesystem::remove(path);
  return 0;
}

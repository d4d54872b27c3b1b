// Where Tally finds its data and keeps its state. Nothing here is a path
// compiled in from the source tree: an install tree, a copy of one, and a
// build tree all find their data from where the binary is.
#pragma once

#include <filesystem>
#include <string>

#include "common/result.hpp"

namespace tally {

// The folder of the running executable (/proc/self/exe).
std::filesystem::path executableDirectory();

// Tally's data folder (shaders/, web/, migrations/), the first that has a
// shaders/ folder of:
//  1. share/tally in the executable's folder or one of its parents: bin/../
//     share/tally in an install tree; build/share/tally in a build tree,
//     where CMake links shaders/ and web/ to the source's folders;
//  2. $TALLY_DATA_DIR.
// Fails naming the places it looked.
Result<std::filesystem::path> dataDirectory();

// The Vulkan layer's manifest file name and the layer's name (layer/).
inline constexpr const char* kLayerManifest = "VkLayer_tally_counters.json";
inline constexpr const char* kLayerName = "VK_LAYER_TALLY_counters";

// The folder that holds the layer's manifest (kLayerManifest), for an
// application captured under the layer (VK_ADD_LAYER_PATH), the first of:
//  1. $TALLY_LAYER_PATH, when set (it must then hold the manifest: a wrong
//     setting fails rather than falling through to another layer);
//  2. <executable's folder>/../layer: a build tree (build/server/tallyd
//     beside build/layer/);
//  3. <executable's folder>/../share/vulkan/explicit_layer.d: an install tree
//     (bin/tallyd).
// Fails naming the places it looked. `executableDir` is for tests.
Result<std::filesystem::path> layerDirectory(const std::filesystem::path& executableDir = executableDirectory());

// The folder for the daemon's own state: $XDG_DATA_HOME/tally, else
// $HOME/.local/share/tally. Fails when neither variable is set.
Result<std::filesystem::path> userDataDirectory();

}  // namespace tally

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

// The folder for the daemon's own state: $XDG_DATA_HOME/tally, else
// $HOME/.local/share/tally. Fails when neither variable is set.
Result<std::filesystem::path> userDataDirectory();

}  // namespace tally

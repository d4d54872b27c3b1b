#include "common/paths.hpp"

#include <cstdlib>
#include <system_error>

namespace tally {
namespace fs = std::filesystem;

fs::path executableDirectory() {
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::current_path(ec) : exe.parent_path();
}

Result<fs::path> dataDirectory() {
  std::error_code ec;
  std::string looked;
  // An install tree is bin/../share/tally; a test binary in build/tests/x/
  // finds build/share/tally three levels up.
  fs::path dir = executableDirectory();
  for (int up = 0; up < 4 && !dir.empty(); ++up) {
    fs::path candidate = dir / "share" / "tally";
    if (fs::is_directory(candidate / "shaders", ec)) return candidate;
    looked += (looked.empty() ? "" : ", ") + candidate.string();
    if (dir == dir.parent_path()) break;
    dir = dir.parent_path();
  }
  if (const char* env = std::getenv("TALLY_DATA_DIR"); env != nullptr && *env != '\0') {
    if (fs::is_directory(fs::path(env) / "shaders", ec)) return fs::path(env);
    looked += std::string(", $TALLY_DATA_DIR (") + env + ")";
  } else {
    looked += ", $TALLY_DATA_DIR (not set)";
  }
  return makeError("no Tally data folder (one with shaders/): looked in " + looked);
}

Result<fs::path> layerDirectory(const fs::path& executableDir) {
  std::error_code ec;
  if (const char* env = std::getenv("TALLY_LAYER_PATH"); env != nullptr && *env != '\0') {
    fs::path dir = fs::absolute(env, ec);
    if (!ec && fs::is_regular_file(dir / kLayerManifest, ec)) return dir.lexically_normal();
    return makeError(std::string("$TALLY_LAYER_PATH (") + env + ") holds no " + kLayerManifest);
  }
  std::string looked = "$TALLY_LAYER_PATH (not set)";
  for (fs::path candidate : {executableDir / ".." / "layer", executableDir / ".." / "share" / "vulkan" / "explicit_layer.d"}) {
    candidate = candidate.lexically_normal();
    if (fs::is_regular_file(candidate / kLayerManifest, ec)) return candidate;
    looked += ", " + candidate.string();
  }
  return makeError(std::string("no Vulkan layer manifest (") + kLayerManifest + "): looked in " + looked +
                   "; build the layer or set TALLY_LAYER_PATH to the folder that holds it");
}

Result<fs::path> userDataDirectory() {
  if (const char* xdg = std::getenv("XDG_DATA_HOME"); xdg != nullptr && *xdg == '/') return fs::path(xdg) / "tally";
  if (const char* home = std::getenv("HOME"); home != nullptr && *home == '/') {
    return fs::path(home) / ".local" / "share" / "tally";
  }
  return makeError("neither $XDG_DATA_HOME nor $HOME is an absolute path: give --db");
}

}  // namespace tally

// The version of this build and the git commit it was built from
// (cmake/version.cmake), printed by --version and recorded with every run.
#pragma once

#include <string>
#include <string_view>

namespace tally {

std::string_view version();    // "0.1.0" (CMake's project version)
std::string_view gitCommit();  // "3e663cd0a1b2", "...-dirty" with uncommitted changes, or "unknown"

// "tallyd 0.1.0 (commit 3e663cd0a1b2)"
inline std::string versionLine(std::string_view program) {
  return std::string(program) + " " + std::string(version()) + " (commit " + std::string(gitCommit()) + ")";
}

}  // namespace tally

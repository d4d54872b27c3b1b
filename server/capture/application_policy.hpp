// What a daemon lets an application or replay spec do (tallyd serve
// --allow-applications; docs/operating.md, "Security model"): the program and
// the replay file must resolve, links followed, inside a folder the operator
// named (--application-root); the spec's env may set only the allowlist's
// variables (the defaults below and --application-env), and never the loader's
// injection points (LD_*, PATH, VK_*LAYER*). The service checks a spec when it
// is posted, and the worker's capture child checks it again before it runs
// (tallyd capture --confine-applications), as a fleet's worker may name
// other folders than its API daemon.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/spec.hpp"
#include "common/result.hpp"

namespace tally::capture {

// The variables a spec may set without the operator's word: the display, the
// Vulkan loader's choice of driver, and Mesa's switches. A trailing '*' makes
// an entry a prefix.
inline constexpr std::array<std::string_view, 18> kDefaultApplicationEnv = {
    "DISPLAY",
    "XAUTHORITY",
    "WAYLAND_DISPLAY",
    "XDG_RUNTIME_DIR",
    "VK_ICD_FILENAMES",  // driver manifests: inside an --application-root or a system icd.d folder
    "VK_DRIVER_FILES",
    "VK_ADD_DRIVER_FILES",
    "VK_LOADER_DRIVERS_SELECT",
    "VK_LOADER_DRIVERS_DISABLE",
    "MESA_*",
    "LIBGL_ALWAYS_SOFTWARE",
    "GALLIUM_DRIVER",
    "LP_NUM_THREADS",
    "DRI_PRIME",
    "__GLX_VENDOR_LIBRARY_NAME",
    "__NV_PRIME_RENDER_OFFLOAD",
    "__NV_PRIME_RENDER_OFFLOAD_PROVIDER",
    "vblank_mode",
};

// Where a driver manifest named by VK_ICD_FILENAMES, VK_DRIVER_FILES or
// VK_ADD_DRIVER_FILES may lie besides the application roots: the loader's
// system folders (a manifest names the library the loader loads).
inline constexpr std::array<std::string_view, 4> kSystemDriverFolders = {
    "/usr/share/vulkan/icd.d", "/usr/local/share/vulkan/icd.d", "/etc/vulkan/icd.d",
    "/usr/local/etc/vulkan/icd.d"};

struct ApplicationPolicy {
  // --application-root: the folders programs and replay files must resolve
  // into. None: this host runs no applications.
  std::vector<std::filesystem::path> roots;
  // --application-env: NAME or PREFIX*, over kDefaultApplicationEnv.
  std::vector<std::string> env;
};

// Why no allowlist may let `name` through (the loader's injection points:
// LD_*, PATH, VK_*LAYER*; TALLY_LAYER_* is Tally's own), or nullopt.
std::optional<std::string> alwaysRefusedEnv(std::string_view name);

// Whether the spec's env may set `name` under this policy.
bool applicationEnvAllowed(const ApplicationPolicy& policy, std::string_view name);

// Checks one --application-env entry (NAME or PREFIX*) at start-up; the
// reason names the entry.
Result<bool> checkApplicationEnvPattern(const std::string& pattern);

// Checks the roots at start-up: each an existing folder, given absolute.
// Returns them resolved (links followed).
Result<std::vector<std::filesystem::path>> checkApplicationRoots(const std::vector<std::string>& roots);

// parseApplicationSpec, held to the policy. Errors name the field:
// "application: this host runs no applications ..." (no roots),
// "application.command[0]: ... outside the --application-root folders",
// "replay: ...", "application.env.LD_PRELOAD: ...". A refused path reads the
// same whether or not the file exists. The spec's program and replay file come
// back resolved (links followed), so that what runs is what was checked.
Result<ApplicationSpec> parseConfinedApplicationSpec(const nlohmann::json& spec,
                                                     const ApplicationPolicy& policy);

}  // namespace tally::capture

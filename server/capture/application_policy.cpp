#include "capture/application_policy.hpp"

#include <cstdlib>

#include "common/json_fields.hpp"

namespace tally::capture {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using json_fields::fieldError;

bool validName(std::string_view name) {
  if (name.empty() || name.size() > 256 || (name[0] >= '0' && name[0] <= '9')) return false;
  for (char c : name) {
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'))
      return false;
  }
  return true;
}

bool matches(std::string_view pattern, std::string_view name) {
  if (!pattern.empty() && pattern.back() == '*')
    return name.starts_with(pattern.substr(0, pattern.size() - 1));
  return pattern == name;
}

// Whether `file` lies in `folder`, both resolved: compared part by part, so
// /srv/apps2 is not inside /srv/apps.
bool under(const fs::path& file, const fs::path& folder) {
  auto f = file.begin();
  for (auto d = folder.begin(); d != folder.end(); ++d, ++f) {
    if (d->empty()) continue;  // a trailing separator
    if (f == file.end() || *f != *d) return false;
  }
  return true;
}

// `given` resolved (links followed) if it exists inside one of `folders`
// (themselves resolved here); nullopt otherwise, whichever the reason.
std::optional<fs::path> resolveInside(const std::string& given, const std::vector<fs::path>& folders) {
  if (given.empty() || given.front() != '/' || given.find('\0') != std::string::npos) return std::nullopt;
  std::error_code ec;
  fs::path real = fs::canonical(given, ec);
  if (ec) return std::nullopt;
  for (const auto& folder : folders) {
    fs::path root = fs::canonical(folder, ec);
    if (!ec && under(real, root)) return real;
  }
  return std::nullopt;
}

std::string rootsText(const ApplicationPolicy& policy) {
  std::string text;
  for (const auto& root : policy.roots) text += (text.empty() ? "" : ", ") + root.string();
  return text;
}

// A driver list (VK_DRIVER_FILES and kin): ':'-separated files or folders,
// each inside an application root or a system icd.d folder.
Result<bool> checkDriverList(const ApplicationPolicy& policy, const std::string& field,
                             const std::string& value) {
  std::vector<fs::path> allowed = policy.roots;
  for (auto folder : kSystemDriverFolders) allowed.emplace_back(folder);
  size_t start = 0;
  while (start <= value.size()) {
    size_t colon = value.find(':', start);
    std::string entry = value.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
    if (!entry.empty() && !resolveInside(entry, allowed)) {
      return fieldError(field, "'" + entry +
                                   "' is not a driver manifest inside an --application-root folder or the "
                                   "system's icd.d folders (a manifest names the library the loader loads)");
    }
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  return true;
}

}  // namespace

std::optional<std::string> alwaysRefusedEnv(std::string_view name) {
  if (name.starts_with("LD_")) return "is the dynamic loader's (LD_*): never settable by a spec";
  if (name == "PATH")
    return "is never settable by a spec (the program is resolved on the daemon's own $PATH)";
  if (name.starts_with("VK_") && name.find("LAYER") != std::string_view::npos)
    return "names Vulkan layers (VK_*LAYER*): never settable by a spec";
  if (name.starts_with("TALLY_LAYER_")) return "is set by Tally to configure the layer; a spec cannot set it";
  return std::nullopt;
}

bool applicationEnvAllowed(const ApplicationPolicy& policy, std::string_view name) {
  if (alwaysRefusedEnv(name)) return false;
  for (auto pattern : kDefaultApplicationEnv) {
    if (matches(pattern, name)) return true;
  }
  for (const auto& pattern : policy.env) {
    if (matches(pattern, name)) return true;
  }
  return false;
}

Result<bool> checkApplicationEnvPattern(const std::string& pattern) {
  const bool prefix = !pattern.empty() && pattern.back() == '*';
  const std::string name = prefix ? pattern.substr(0, pattern.size() - 1) : pattern;
  if (!validName(name)) {
    return makeError("--application-env " + pattern +
                     ": expected a variable name (letters, digits and _) or a prefix ending in '*'");
  }
  if (auto why = alwaysRefusedEnv(name))
    return makeError("--application-env " + pattern + ": " + name + " " + *why);
  // A prefix that covers a refused family ("L*") still never lets one through (applicationEnvAllowed).
  return true;
}

Result<std::vector<fs::path>> checkApplicationRoots(const std::vector<std::string>& roots) {
  std::vector<fs::path> resolved;
  for (const auto& root : roots) {
    if (root.empty() || root.front() != '/')
      return makeError("--application-root " + root + ": must be an absolute path");
    std::error_code ec;
    fs::path real = fs::canonical(root, ec);
    if (ec || !fs::is_directory(real, ec)) return makeError("--application-root " + root + ": not a folder");
    if (real == "/")
      return makeError("--application-root " + root + ": the whole file system is not a confinement");
    resolved.push_back(real);
  }
  return resolved;
}

Result<ApplicationSpec> parseConfinedApplicationSpec(const json& spec, const ApplicationPolicy& policy) {
  if (!spec.is_object()) return fieldError("spec", "must be a JSON object");
  const bool replay = !spec.contains("application");
  const std::string key = replay ? "replay" : "application";
  if (policy.roots.empty()) {
    return fieldError(key,
                      "this host runs no applications: it has no --application-root folder (tallyd serve "
                      "--allow-applications --application-root DIR)");
  }
  const std::string outside =
      "must resolve (links followed) to a file inside the daemon's --application-root "
      "folders (" +
      rootsText(policy) + ")";
  // Paths first: a path outside the roots is refused alike whether or not it
  // exists, so a spec learns nothing of the host's other files.
  std::optional<fs::path> program, replayFile;
  if (replay) {
    const json& file = spec["replay"];
    if (file.is_string()) {
      const std::string given = file.get<std::string>();
      if (given.empty() || given.front() != '/')
        return fieldError("replay", "must be an absolute path on the daemon's host");
      replayFile = resolveInside(given, policy.roots);
      if (!replayFile) return fieldError("replay", outside);
    }
  } else {
    const json& app = spec["application"];
    if (app.is_object() && app.contains("command") && app["command"].is_array() && !app["command"].empty() &&
        app["command"][0].is_string()) {
      const std::string given = app["command"][0].get<std::string>();
      std::string path = given;
      if (given.find('/') == std::string::npos) {
        const char* pathEnv = std::getenv("PATH");
        path = findOnPath(given, pathEnv ? pathEnv : "");
        if (path.empty()) {
          return fieldError("application.command[0]",
                            "'" + given + "' is not an executable in any folder of $PATH");
        }
      } else if (given.front() != '/') {
        return fieldError("application.command[0]",
                          "must be a program name (looked up on the daemon's $PATH) or an absolute path");
      }
      program = resolveInside(path, policy.roots);
      if (!program) return fieldError("application.command[0]", "'" + given + "' " + outside);
    }
  }

  auto parsed = parseApplicationSpec(spec, "/");
  if (!parsed) return parsed;
  const std::string prefix = parsed->fieldPrefix() + "env.";
  for (const auto& [name, value] : parsed->env) {
    if (auto why = alwaysRefusedEnv(name)) return fieldError(prefix + name, *why);
    if (!applicationEnvAllowed(policy, name)) {
      return fieldError(
          prefix + name,
          "not among the variables this daemon lets a spec set (the display, the Vulkan loader's "
          "driver choice, MESA_*, ...: docs/operating.md, \"Security model\"; the operator adds names "
          "with --application-env)");
    }
    if (name == "VK_ICD_FILENAMES" || name == "VK_DRIVER_FILES" || name == "VK_ADD_DRIVER_FILES") {
      auto drivers = checkDriverList(policy, prefix + name, value);
      if (!drivers) return drivers.failure();
    }
  }
  if (program) parsed->program = program->string();
  if (replayFile) parsed->replayFile = replayFile->string();
  return parsed;
}

}  // namespace tally::capture

// Admission of a capture spec: its parser, the server's limits on what one
// capture may render, glTF paths confined to the scene folders, and
// applications only where the daemon allows them.
#include "service/admission.hpp"

#include <system_error>

#include "capture/spec.hpp"
#include "service/errors.hpp"
#include "sweeps/sweep.hpp"

namespace tally::service::detail {
namespace fs = std::filesystem;
using nlohmann::json;

bool under(const fs::path& file, const fs::path& folder) {
  auto f = file.begin(), d = folder.begin();
  for (; d != folder.end(); ++d, ++f) {
    if (d->empty()) continue;  // a trailing separator
    if (f == file.end() || *f != *d) return false;
  }
  return true;
}

// Resolves a glTF path against the scene folders: relative paths are looked
// up in each folder, absolute ones must lie in one; symlinks are followed
// before the check, so a link cannot escape. Returns the canonical path.
std::string resolveGltf(const ServiceOptions& options, const std::string& given, const std::string& field) {
  if (options.sceneFolders.empty()) invalid(field, "glTF scenes are not enabled (the daemon has no --scenes folder)");
  if (given.size() > 4096 || given.find('\0') != std::string::npos) invalid(field, "not a valid path");
  fs::path p(given);
  for (const auto& part : p) {
    if (part == "..") invalid(field, "must not contain '..'");
  }
  std::error_code ec;
  for (const auto& folder : options.sceneFolders) {
    fs::path root = fs::canonical(folder, ec);
    if (ec) continue;
    fs::path candidate = p.is_absolute() ? p : root / p;
    fs::path real = fs::canonical(candidate, ec);
    if (ec) continue;
    if (!under(real, root)) {
      if (p.is_absolute()) continue;
      invalid(field, "resolves outside the scene folders");
    }
    if (!fs::is_regular_file(real, ec)) invalid(field, "not a file");
    auto ext = real.extension().string();
    if (ext != ".gltf" && ext != ".glb") invalid(field, "must be a .gltf or .glb file");
    return real.string();
  }
  invalid(field, "no such file under the scene folders");
}

// An application or a replay under the Vulkan layer: a program runs on this
// host, so only where the daemon allows it, for the application token, and
// only as the policy lets it (capture/application_policy.hpp). Paths are the
// host's: a program by name (looked up on the daemon's $PATH) or absolute, a
// replay file absolute, each resolving inside an --application-root.
json validateApplicationSpec(const ServiceContext& ctx, const json& body, api::Principal principal) {
  const std::string key = body.contains("application") ? "application" : "replay";
  if (!ctx.options.allowApplications) {
    invalid(key, "this daemon does not run applications (tallyd serve --allow-applications enables them)");
  }
  if (principal != api::Principal::kApplication) {
    throw RequestError(
        403, api::code::kForbidden,
        "running an application needs the application token (the token file's application= line); "
        "this token may capture but not run programs",
        "Authorization");
  }
  auto parsed = capture::parseConfinedApplicationSpec(body, ctx.options.applicationPolicy);
  if (!parsed) throw RequestError(400, api::code::kInvalidField, parsed.error(), parsed.failure().field());
  return body;
}

json validateContent(const ServiceContext& ctx, const json& body, api::Principal principal);

// The spec's "device" picks the hosts that may run it (docs/fleet.md); the
// rest is the capture, sweep or application spec, checked by its parser.
json validateSpec(const ServiceContext& ctx, const json& body, api::Principal principal) {
  if (!body.is_object()) throw RequestError(400, api::code::kBadJson, "the body must be a capture spec (a JSON object)");
  if (!body.contains("device")) return validateContent(ctx, body, principal);
  auto requirement = store::parseDeviceRequirement(body);
  if (!requirement) throw RequestError(400, api::code::kInvalidField, requirement.error(), requirement.failure().field());
  json content = body;
  content.erase("device");
  json stored = validateContent(ctx, content, principal);
  stored["device"] = body["device"];
  return stored;
}

json validateContent(const ServiceContext& ctx, const json& body, api::Principal principal) {
  // {"application": ...} or {"replay": ...}: its parser names any field of a
  // capture matrix or a sweep beside it.
  if (capture::isApplicationSpec(body)) return validateApplicationSpec(ctx, body, principal);
  // A stability sweep ({"sweep": NAME, ...}) is checked by its own parser; its
  // limits on points and resolution are the sweep's (sweeps/sweep.hpp).
  if (sweeps::isSweepSpec(body)) {
    auto sweep = sweeps::parseSweepSpec(body, ctx.rendererNames);
    if (!sweep) throw RequestError(400, api::code::kInvalidField, sweep.error(), sweep.failure().field());
    return body;
  }
  auto parsed = capture::parseCaptureSpec(body, ctx.rendererNames);
  if (!parsed) {
    throw RequestError(400, api::code::kInvalidField, parsed.error(), parsed.failure().field());
  }
  const auto& spec = *parsed;
  const auto& options = ctx.options;
  for (size_t i = 0; i < spec.resolutions.size(); ++i) {
    uint64_t pixels = uint64_t(spec.resolutions[i].width) * spec.resolutions[i].height;
    if (pixels > options.maxPixels) {
      invalid("resolutions[" + std::to_string(i) + "]",
              "at most " + std::to_string(options.maxPixels) + " pixels on this server, got " + std::to_string(pixels));
    }
  }
  if (spec.frames > options.maxFrames) {
    invalid("frames", "at most " + std::to_string(options.maxFrames) + " on this server");
  }
  // A heatmap counts every pose it may place (cells x yaws).
  size_t cameras = spec.camerasPerScene();
  if (spec.sampleCount(cameras) > options.maxMatrix) {
    invalid("spec", "the matrix (renderers x scenes x resolutions x cameras) has " +
                        std::to_string(spec.sampleCount(cameras)) + " samples; at most " +
                        std::to_string(options.maxMatrix) + " on this server");
  }
  // What it renders: samples x frames x pixels (capture::CaptureSpec::cost).
  if (uint64_t cost = spec.cost(); cost > options.maxCost) {
    invalid("spec", "the capture's cost (samples x frames x pixels) is " + std::to_string(cost) +
                        " pixel-frames; at most " + std::to_string(options.maxCost) +
                        " on this server (max_cost; fewer frames, resolutions or cameras)");
  }
  // glTF paths are resolved (a stat per scene folder; the file is loaded by
  // the capture), and two spellings of one file are one scene.
  json stored = body;
  if (stored.contains("scenes")) {
    std::vector<std::pair<std::string, size_t>> files;  // resolved path, index
    for (size_t i = 0; i < stored["scenes"].size(); ++i) {
      json& s = stored["scenes"][i];
      if (s.is_object() && s.contains("gltf")) {
        std::string field = "scenes[" + std::to_string(i) + "].gltf";
        s["gltf"] = resolveGltf(options, s["gltf"].get<std::string>(), field);
        for (const auto& [path, k] : files) {
          if (path == s["gltf"] &&
              stored["scenes"][k].value("max_texture_size", json()) == s.value("max_texture_size", json())) {
            invalid("scenes[" + std::to_string(i) + "]",
                    "a duplicate of scenes[" + std::to_string(k) + "] (each entry must differ)");
          }
        }
        files.emplace_back(s["gltf"].get<std::string>(), i);
      }
    }
  }
  return stored;
}

store::QueueLimits queueLimits(const ServiceContext& ctx, const api::Request& req) {
  store::QueueLimits limits;
  limits.client = req.client;
  limits.maxQueued = ctx.options.maxQueued;
  limits.maxQueuedPerClient = ctx.options.maxQueuedPerClient;
  return limits;
}

void refuseQueued(const ServiceContext& ctx, const store::CreatedJob& created) {
  if (ctx.onQueueLimited) ctx.onQueueLimited(created.refused);
  const bool mine = created.refused == "client";
  RequestError refused(429, api::code::kTooManyRequests,
                       (mine ? "this client has " : "the queue holds ") + std::to_string(created.queued) +
                           " queued captures, the limit " + (mine ? "per client" : "of this server") + " (" +
                           (mine ? "max_queued_per_client " + std::to_string(ctx.options.maxQueuedPerClient)
                                 : "max_queued " + std::to_string(ctx.options.maxQueued)) +
                           "); try again once some have run");
  refused.headers.emplace_back("Retry-After", std::to_string(ctx.options.retryAfterSeconds));
  throw refused;
}

}  // namespace tally::service::detail

#include "capture/sweep.hpp"

#include "gpu/context.hpp"

namespace tally::capture {

std::vector<std::string> sweepNames() { return {std::string(kDepthSweepName)}; }

bool isSweepSpec(const nlohmann::json& spec) { return spec.is_object() && spec.contains("sweep"); }

Result<SweepSpec> parseSweepSpec(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers) {
  if (!isSweepSpec(spec)) return makeError("sweep: required");
  const auto& name = spec["sweep"];
  std::string known;
  for (const auto& n : sweepNames()) known += (known.empty() ? "" : ", ") + n;
  if (!name.is_string()) return makeError("sweep: must be a sweep name (one of " + known + ")");
  if (name.get<std::string>() == kDepthSweepName) {
    auto depth = parseDepthSweepSpec(spec, knownRenderers);
    if (!depth) return makeError(depth.error());
    return SweepSpec(std::move(depth).value());
  }
  return makeError("sweep: unknown sweep '" + name.get<std::string>() + "' (expected one of " + known + ")");
}

Result<nlohmann::json> runSweep(const SweepSpec& spec, const CaptureOptions& options) {
  return withDevice(options.device, [&](gpu::Context& ctx) {
    return std::visit([&](const auto& s) { return runDepthSweep(ctx, s, options); }, spec);
  });
}

}  // namespace tally::capture

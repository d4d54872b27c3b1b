#include "capture/sweep.hpp"

#include "gpu/context.hpp"

namespace tally::capture {

std::vector<std::string> sweepNames() {
  return {std::string(kDepthSweepName), std::string(kIdSweepName), std::string(kEdgesSweepName),
          std::string(kPrecisionSweepName), std::string(kCounterSweepName)};
}

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
  if (name.get<std::string>() == kIdSweepName) {
    auto ids = parseIdSweepSpec(spec, knownRenderers);
    if (!ids) return makeError(ids.error());
    return SweepSpec(std::move(ids).value());
  }
  if (name.get<std::string>() == kEdgesSweepName) {
    auto edges = parseEdgesSweepSpec(spec, knownRenderers);
    if (!edges) return makeError(edges.error());
    return SweepSpec(std::move(edges).value());
  }
  if (name.get<std::string>() == kPrecisionSweepName) {
    auto precision = parsePrecisionSweepSpec(spec);
    if (!precision) return makeError(precision.error());
    return SweepSpec(std::move(precision).value());
  }
  if (name.get<std::string>() == kCounterSweepName) {
    auto counter = parseCounterSweepSpec(spec, knownRenderers);
    if (!counter) return makeError(counter.error());
    return SweepSpec(std::move(counter).value());
  }
  return makeError("sweep: unknown sweep '" + name.get<std::string>() + "' (expected one of " + known + ")");
}

namespace {

// One overload per sweep kind: runSweep's visit picks it by the spec's type.
Result<nlohmann::json> runSweepKind(gpu::Context& ctx, const DepthSweepSpec& spec, const CaptureOptions& options) {
  return runDepthSweep(ctx, spec, options);
}
Result<nlohmann::json> runSweepKind(gpu::Context& ctx, const IdSweepSpec& spec, const CaptureOptions& options) {
  return runIdSweep(ctx, spec, options);
}
Result<nlohmann::json> runSweepKind(gpu::Context& ctx, const EdgesSweepSpec& spec, const CaptureOptions& options) {
  return runEdgesSweep(ctx, spec, options);
}
Result<nlohmann::json> runSweepKind(gpu::Context& ctx, const PrecisionSweepSpec& spec,
                                    const CaptureOptions& options) {
  return runPrecisionSweep(ctx, spec, options);
}

Result<nlohmann::json> runSweepKind(gpu::Context& ctx, const CounterSweepSpec& spec, const CaptureOptions& options) {
  return runCounterSweep(ctx, spec, options);
}

}  // namespace

Result<nlohmann::json> runSweep(const SweepSpec& spec, const CaptureOptions& options) {
  return withDevice(options.device, [&](gpu::Context& ctx) {
    return std::visit([&](const auto& s) { return runSweepKind(ctx, s, options); }, spec);
  });
}

}  // namespace tally::capture

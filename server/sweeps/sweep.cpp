#include "sweeps/sweep.hpp"

#include "sweeps/fields.hpp"

namespace tally::sweeps {
namespace {

// Adapts a sweep's own parser to the registry's signature.
template <class Spec, Result<Spec> (*Parse)(const nlohmann::json&, const std::vector<std::string>&)>
Result<SweepSpec> parseAs(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers) {
  auto parsed = Parse(spec, knownRenderers);
  if (!parsed) return parsed.failure();
  return SweepSpec(std::move(parsed).value());
}

// The precision sweep draws its own scene with one renderer, so takes no renderer list.
Result<PrecisionSweepSpec> parsePrecision(const nlohmann::json& spec, const std::vector<std::string>&) {
  return parsePrecisionSweepSpec(spec);
}

constexpr SweepKind kSweeps[] = {
    {kDepthSweepName, parseAs<DepthSweepSpec, parseDepthSweepSpec>},
    {kIdSweepName, parseAs<IdSweepSpec, parseIdSweepSpec>},
    {kEdgesSweepName, parseAs<EdgesSweepSpec, parseEdgesSweepSpec>},
    {kPrecisionSweepName, parseAs<PrecisionSweepSpec, parsePrecision>},
    {kCounterSweepName, parseAs<CounterSweepSpec, parseCounterSweepSpec>},
};

// One overload per sweep kind: runSweep's visit picks it by the spec's type.
Result<nlohmann::json> runKind(gpu::Context& ctx, const DepthSweepSpec& spec, const SweepOptions& options) {
  return runDepthSweep(ctx, spec, options);
}
Result<nlohmann::json> runKind(gpu::Context& ctx, const IdSweepSpec& spec, const SweepOptions& options) {
  return runIdSweep(ctx, spec, options);
}
Result<nlohmann::json> runKind(gpu::Context& ctx, const EdgesSweepSpec& spec, const SweepOptions& options) {
  return runEdgesSweep(ctx, spec, options);
}
Result<nlohmann::json> runKind(gpu::Context& ctx, const PrecisionSweepSpec& spec, const SweepOptions& options) {
  return runPrecisionSweep(ctx, spec, options);
}
Result<nlohmann::json> runKind(gpu::Context& ctx, const CounterSweepSpec& spec, const SweepOptions& options) {
  return runCounterSweep(ctx, spec, options);
}

}  // namespace

std::span<const SweepKind> sweepKinds() { return kSweeps; }

std::vector<std::string> sweepNames() {
  std::vector<std::string> names;
  for (const auto& kind : kSweeps) names.emplace_back(kind.name);
  return names;
}

bool isSweepSpec(const nlohmann::json& spec) { return spec.is_object() && spec.contains("sweep"); }

Result<SweepSpec> parseSweepSpec(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers) {
  if (!isSweepSpec(spec)) return Error("sweep", "required");
  const auto& name = spec["sweep"];
  const std::string known = fields::joined(sweepNames());
  if (!name.is_string()) return Error("sweep", "must be a sweep name (one of " + known + ")");
  for (const auto& kind : kSweeps) {
    if (name.get<std::string>() == kind.name) return kind.parse(spec, knownRenderers);
  }
  return Error("sweep", "unknown sweep '" + name.get<std::string>() + "' (expected one of " + known + ")");
}

Result<nlohmann::json> runSweep(gpu::Context& ctx, const SweepSpec& spec, const SweepOptions& options) {
  return std::visit([&](const auto& s) { return runKind(ctx, s, options); }, spec);
}

}  // namespace tally::sweeps

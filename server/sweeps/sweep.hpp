// Stability sweeps: capture kinds that vary one numeric parameter of a method
// until it breaks, and state where it does. Every sweep spec has the frame
// {"sweep": NAME, ...} and every result the shape
//   {"sweep": NAME, "parameters": [...], "points": [{<param>: value, ...,
//    "error": {...}}], "threshold": {...}, "fails_at": {...} | null,
//    "device": {...}, "spec": {...}}
// (docs/result-schema.md, "Sweep results"). A spec with "sweep" goes to the
// capture runner (capture::runSweep), which opens the device and calls the sweep
// named here the way it calls a renderer: by name, through this registry.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "sweeps/counter.hpp"
#include "sweeps/depth.hpp"
#include "sweeps/edges.hpp"
#include "sweeps/id.hpp"
#include "sweeps/precision.hpp"
#include "sweeps/options.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"

namespace tally::sweeps {

// One alternative per sweep kind.
using SweepSpec = std::variant<DepthSweepSpec, IdSweepSpec, EdgesSweepSpec, PrecisionSweepSpec, CounterSweepSpec>;

// A registered sweep: its name and its spec parser. Running is by the parsed
// spec's type (one run function per alternative of SweepSpec).
struct SweepKind {
  std::string_view name;
  Result<SweepSpec> (*parse)(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers);
};

// Every sweep, in the order the docs list them.
std::span<const SweepKind> sweepKinds();

// "depth-reconstruction", "id-capacity", "material-edges", "visbuffer-precision", "counter-headroom"
std::vector<std::string> sweepNames();

bool isSweepSpec(const nlohmann::json& spec);  // an object with "sweep"

// Errors name the field: "sweep: unknown sweep 'x' (expected one of ...)".
Result<SweepSpec> parseSweepSpec(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers);

// Runs the sweep on an open device.
Result<nlohmann::json> runSweep(gpu::Context& ctx, const SweepSpec& spec, const SweepOptions& options);

}  // namespace tally::sweeps

// Sweep "counter-headroom": how far a counter slot is from wrapping, against
// resolution times overshading (docs/measurement.md, "Counter overflow"). Each
// point renders one instrumented frame of the `planes` scene (layers stacked
// back to front, so every layer is shaded: overshading = layers exactly) at
// one resolution and reads the largest count one counter slot reached. A slot
// counts every access its site makes in the frame, so that count is the load
// (pixels x fragments per pixel of the heaviest pass) times a constant per
// fragment; the point where it reaches 2^bits is where a counter of that many
// bits wraps. fails_at states that load, predicted from the measured counts
// per fragment, and the smallest measured load that did reach it, which a
// small `bits` (16, say) lets a sweep see happen. The wrap itself is proven
// exact for Tally's 64-bit counters by tests/integration/overflow_test.cpp,
// which preloads counters just below 2^32.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "sweeps/options.hpp"
#include "common/resolution.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"

namespace tally::sweeps {

inline constexpr std::string_view kCounterSweepName = "counter-headroom";

struct CounterSweepSpec {
  std::vector<std::string> renderers = {"forward"};
  std::vector<uint32_t> layers;           // planes scene layers: the overshading
  std::vector<Resolution> resolutions;
  uint32_t lights = 400;
  int bits = 32;                          // the counter width whose wrap fails
  nlohmann::json source;
};

Result<CounterSweepSpec> parseCounterSweepSpec(const nlohmann::json& spec,
                                               const std::vector<std::string>& knownRenderers);

Result<nlohmann::json> runCounterSweep(gpu::Context& ctx, const CounterSweepSpec& spec,
                                       const SweepOptions& options);

}  // namespace tally::sweeps

// Shared pieces of the integration tests: the device (TALLY_TEST_DEVICE),
// the shader folder (TALLY_SHADER_DIR), counter sums per site kind, the
// sampled-mode error bound, and the stats file.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "gpu/context.hpp"
#include "spirv/instrument.hpp"

namespace tally::test {

// The process-wide context, created on first use with ContextOptions::device
// from TALLY_TEST_DEVICE ("" when unset: the usual choice). Null with the
// reason in *error when it cannot be created.
const gpu::Context* testContext(std::string* error);

// The integration shaders: TALLY_SHADER_DIR if set (the binary was moved,
// tests/gpu/), else the source folder compiled in.
std::string shaderDir();

// Sum of the counters of every distinct slot range of the sites of `kind` in `stage`.
uint64_t sumKind(const std::vector<spirv::Site>& sites, const std::vector<uint64_t>& counters,
                 spirv::SiteKind kind, spirv::Stage stage);
// How many distinct slot ranges (resources) the sites of `kind` in `stage` use.
size_t slotRanges(const std::vector<spirv::Site>& sites, spirv::SiteKind kind, spirv::Stage stage);

// The tile of sampled:N, as docs/measurement.md states it: th is the largest
// divisor of N with th*th <= N, tw = N / th (x extent tw, y extent th).
struct TileShape {
  uint32_t width = 1;
  uint32_t height = 1;
};
TileShape tileShape(uint32_t n);

// Tiles of `tile` (aligned at 0,0) that a W x H rectangle at the origin covers only partly.
uint64_t partialTiles(uint32_t width, uint32_t height, TileShape tile);

// The documented bound of sampled:N over a W x H region with k accesses per
// invocation: N * k * partialTiles. 0 for exact and subgroup modes.
uint64_t sampledBound(const spirv::Mode& mode, uint32_t width, uint32_t height,
                      uint64_t accessesPerInvocation);

// Appends one JSON object as a line to exactness_stats.json in the working directory.
void appendStatsLine(const nlohmann::json& line);

// The modes that count exactly, in every counter width the device can run:
// exact, subgroup and accumulate with each of its flushes.
std::vector<std::pair<spirv::Mode, spirv::CounterWidth>> exactModes(const gpu::Context& ctx);

// "exact", "exact/uint32_pair", "subgroup", "sampled:16" ...
std::string modeLabel(const spirv::Mode& mode, spirv::CounterWidth width);

}  // namespace tally::test

// Runs sweeps on the default device the way `tallyd capture` does (parse,
// open the device, run).
#pragma once

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "renderers/renderer.hpp"
#include "sweeps/sweep.hpp"

namespace tally::sweeps::fixture {

// A parsed spec: the result, or why the device or the sweep refused.
inline Result<nlohmann::json> run(const SweepSpec& spec, const SweepOptions& options = {}) {
  return gpu::withDevice("", [&](gpu::Context& ctx) { return runSweep(ctx, spec, options); });
}

// A spec as JSON, failing the test with the reason if parsing or the run
// fails; {} then.
inline nlohmann::json runSpec(const nlohmann::json& spec, const SweepOptions& options = {}) {
  auto parsed = parseSweepSpec(spec, renderers::rendererNames());
  EXPECT_TRUE(parsed.ok()) << parsed.error();
  if (!parsed) return {};
  auto result = run(*parsed, options);
  EXPECT_TRUE(result.ok()) << result.error();
  return result ? *result : nlohmann::json{};
}

}  // namespace tally::sweeps::fixture

// Sites in loops (docs/measurement.md, "Sites in loops"): the accumulate
// mode derives them from a trip counter per loop, added once before a
// counted loop. Every loop shape, in compute and in a fragment shader that
// ends part-way through a loop, against counts derived by hand in the
// shaders' headers, in every exact mode, and site by site against exact.
#include <algorithm>
#include <bit>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gpu_fixture.hpp"
#include "passes.hpp"

namespace tally::test {
namespace {

using spirv::SiteKind;
using spirv::Stage;

// Buffer loads of one in-bounds invocation of loop_shapes.comp.glsl (its header).
uint64_t loopShapeLoads(uint32_t width, uint32_t index) {
  const uint64_t bits = std::bit_width(index);
  const uint32_t pushed = width % 7;
  return 10 + pushed + 0 + (pushed > 5 ? pushed - 5 : 0) + 1 + (7 * index + 1) % 4 + 5 + 12 + 6 + 4 + 4 + 2 * bits + 2 * std::max(1u, index & 3u) +
         (2 * (index % 4) + 1) + 9 + (3 + 2 * 3) + 7 * (width % 7) + 2 * (3 + index % 5);
}

bool noteContains(const PassRun& run, const std::string& part) {
  return std::any_of(run.notes.begin(), run.notes.end(),
                     [&](const std::string& n) { return n.find(part) != std::string::npos; });
}

// Each site's own count (perSite) against the exact mode's.
void expectSameSites(const PassRun& run, const PassRun& exact, const std::string& where) {
  ASSERT_EQ(run.sites.size(), exact.sites.size()) << where;
  for (size_t i = 0; i < exact.sites.size(); ++i) {
    const auto& s = exact.sites[i];
    for (uint32_t k = 0; k < std::max(s.slotCount, 1u); ++k) {
      EXPECT_EQ(run.counters.at(run.sites[i].slot + k), exact.counters.at(s.slot + k))
          << where << ": site " << i << " (" << s.resource << ", instruction " << s.instruction << ")";
    }
  }
}

TEST(LoopShapes, EveryShapeCountsAsByHandAndAsExact) {
  std::string why;
  const gpu::Context* ctx = testContext(&why);
  ASSERT_NE(ctx, nullptr) << why;
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{37, 21}, {20, 13}}) {
    ComputePass pass(*ctx, w, h, "loop_shapes.comp.glsl");
    uint64_t loads = 0;
    for (uint32_t i = 0; i < w * h; ++i) loads += loopShapeLoads(w, i);
    auto exact = pass.run({*spirv::parseMode("exact"), spirv::CounterWidth::Uint32Pair, 1, {}, 0, true, true});
    ASSERT_TRUE(exact.ok()) << exact.error();
    for (const auto& [mode, width] : exactModes(*ctx)) {
      for (bool perSite : {false, true}) {
        const std::string where = std::to_string(w) + "x" + std::to_string(h) + " " + modeLabel(mode, width) +
                                  (perSite ? " per site" : "");
        auto run = pass.run({mode, width, 1, {}, 0, true, perSite});
        ASSERT_TRUE(run.ok()) << run.error();
        EXPECT_EQ(sumKind(run->sites, run->counters, SiteKind::BufferRead, Stage::Compute), loads) << where;
        EXPECT_EQ(sumKind(run->sites, run->counters, SiteKind::BufferWrite, Stage::Compute), uint64_t(w) * h)
            << where;
        if (perSite) expectSameSites(*run, *exact, where);
        if (mode.kind == spirv::CountMode::Accumulate) {
          // Live: loops derived, and counted loops added once at their entry.
          EXPECT_TRUE(noteContains(*run, "compute sites in loops derived from")) << where;
          EXPECT_FALSE(noteContains(*run, "(0 added once")) << where;
          EXPECT_TRUE(noteContains(*run, "1 of those adds derived from an enclosing count")) << where;
        }
      }
    }
  }
}

class LoopEnd : public ::testing::TestWithParam<const char*> {};

// The invocation ends (discard) or stops being counted (demote) in the
// second iteration, between sites that share the loop's trip counter and
// one that does not.
TEST_P(LoopEnd, CountsStopWhereTheInvocationEndsInTheLoop) {
  std::string why;
  const gpu::Context* ctx = testContext(&why);
  ASSERT_NE(ctx, nullptr) << why;
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{333, 197}, {157, 91}}) {
    FragmentPass pass(*ctx, w, h, std::nullopt, GetParam());
    const uint64_t kept = uint64_t(w - 100) * h, left = 100ull * h;
    auto exact = pass.run({*spirv::parseMode("exact"), spirv::CounterWidth::Uint32Pair, 1, {}, 0, true, true});
    ASSERT_TRUE(exact.ok()) << exact.error();
    for (const auto& [mode, width] : exactModes(*ctx)) {
      const std::string where = std::string(GetParam()) + " " + std::to_string(w) + "x" + std::to_string(h) + " " +
                                modeLabel(mode, width);
      auto run = pass.run({mode, width, 1, {}, 0, true, true});
      ASSERT_TRUE(run.ok()) << run.error();
      auto reads = [&](const std::string& resource) {
        uint64_t n = 0;
        for (const auto& s : run->sites) {
          if (s.kind == SiteKind::TextureRead && s.resource == resource) n += run->counters.at(s.slot);
        }
        return n;
      };
      EXPECT_EQ(reads("albedo"), 7 * kept + 2 * left) << where;
      EXPECT_EQ(reads("detail"), 4 * kept + 2 * left) << where;
      EXPECT_EQ(reads("mask"), 4 * kept + left) << where;
      EXPECT_EQ(sumKind(run->sites, run->counters, SiteKind::OutputWrite, Stage::Fragment), kept) << where;
      expectSameSites(*run, *exact, where);
      if (mode.kind == spirv::CountMode::Accumulate) {
        EXPECT_TRUE(noteContains(*run, "fragment sites in loops derived from 2 trip counters (1 added once")) << where;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Shaders, LoopEnd, ::testing::Values("loop_discard.frag.glsl", "loop_demote.frag.glsl"),
                         [](const auto& shader) {
                           return std::string(shader.param).substr(5, std::string(shader.param).find('.') - 5);
                         });

}  // namespace
}  // namespace tally::test

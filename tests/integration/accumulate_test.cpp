// Where invocations end early, and where one invocation counts past 16 bits:
// the cases the accumulate mode's flush must get right, run in every exact
// mode on the device (lavapipe in CI) against counts derived by hand in the
// shaders' headers.
//  - discard_left / demote_left: the left 100 columns end (OpKill) or turn
//    into helpers (OpDemoteToHelperInvocation) after two of five reads;
//  - long_loop: 70008 buffer loads per invocation, both 16-bit halves of the
//    flush's reduction non-zero where every load adds in the shader;
//  - cached_arrays: reads through a 20-element descriptor array, cached per
//    site and flushed in one waterfall, against counts per element by hand.
#include <array>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gpu_fixture.hpp"
#include "passes.hpp"

namespace tally::test {
namespace {

using spirv::CounterWidth;
using spirv::SiteKind;
using spirv::Stage;

// Sum over the slots of the sites of `kind` on the resource named `resource`.
uint64_t sumResource(const PassRun& run, SiteKind kind, const std::string& resource) {
  std::vector<spirv::Site> picked;
  for (const auto& s : run.sites) {
    if (s.kind == kind && s.resource == resource) picked.push_back(s);
  }
  return sumKind(picked, run.counters, kind, Stage::Fragment) + sumKind(picked, run.counters, kind, Stage::Compute);
}

const gpu::Context* deviceOrSkip(std::string& why) { return testContext(&why); }

// Runs `pass` in every exact mode the device can, handing each run and its label to `check`.
template <class Pass, class Check>
void forEachExactMode(const gpu::Context& ctx, Pass& pass, Check check) {
  for (const auto& [mode, width] : exactModes(ctx)) {
    auto run = pass.run({mode, width, 1});
    ASSERT_TRUE(run.ok()) << run.error();
    check(*run, modeLabel(mode, width));
  }
}

class EarlyEnd : public ::testing::TestWithParam<const char*> {};

TEST_P(EarlyEnd, CountsStopWhereTheInvocationEnds) {
  std::string why;
  const gpu::Context* ctx = deviceOrSkip(why);
  ASSERT_NE(ctx, nullptr) << why;
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{333, 197}, {157, 91}}) {
    FragmentPass pass(*ctx, w, h, std::nullopt, GetParam());
    const uint64_t all = uint64_t(w) * h, kept = uint64_t(w - 100) * h;
    forEachExactMode(*ctx, pass, [&](const PassRun& run, const std::string& label) {
      const std::string where = std::string(GetParam()) + " " + std::to_string(w) + "x" + std::to_string(h) + " " + label;
      EXPECT_EQ(sumResource(run, SiteKind::TextureRead, "albedo"), all + kept) << where;
      EXPECT_EQ(sumResource(run, SiteKind::TextureRead, "detail"), all + kept) << where;
      EXPECT_EQ(sumResource(run, SiteKind::TextureRead, "mask"), kept) << where;
      EXPECT_EQ(sumKind(run.sites, run.counters, SiteKind::OutputWrite, Stage::Fragment), kept) << where;
      EXPECT_EQ(sumKind(run.sites, run.counters, SiteKind::Invocation, Stage::Fragment), all) << where;
    });
  }
}

INSTANTIATE_TEST_SUITE_P(Shaders, EarlyEnd, ::testing::Values("discard_left.frag.glsl", "demote_left.frag.glsl"),
                         [](const auto& shader) { return std::string(shader.param).substr(0, std::string(shader.param).find('_')); });

// Sites that run exactly once in every invocation are derived from the
// invocation count in accumulate mode; those after an early return, in a
// loop or in a function called on one branch are counted in the shader.
// Counts by hand in return_left.frag.glsl's header, the same in every mode.
TEST(EarlyReturn, DerivedAndCountedSitesAgreeWithTheCountsByHand) {
  std::string why;
  const gpu::Context* ctx = deviceOrSkip(why);
  ASSERT_NE(ctx, nullptr) << why;
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{333, 197}, {157, 91}}) {
    FragmentPass pass(*ctx, w, h, std::nullopt, "return_left.frag.glsl");
    const uint64_t all = uint64_t(w) * h, kept = uint64_t(w - 100) * h, left = 100ull * h;
    forEachExactMode(*ctx, pass, [&](const PassRun& run, const std::string& label) {
      const std::string where = std::to_string(w) + "x" + std::to_string(h) + " " + label;
      EXPECT_EQ(sumResource(run, SiteKind::TextureRead, "albedo"), 2 * all) << where;
      EXPECT_EQ(sumResource(run, SiteKind::TextureRead, "detail"), kept) << where;
      EXPECT_EQ(sumResource(run, SiteKind::TextureRead, "mask"), 3 * kept + left) << where;
      EXPECT_EQ(sumKind(run.sites, run.counters, SiteKind::OutputWrite, Stage::Fragment), all) << where;
      EXPECT_EQ(sumKind(run.sites, run.counters, SiteKind::Invocation, Stage::Fragment), all) << where;
      // The derivation is live in accumulate mode: both albedo reads and the output.
      bool derived = false;
      for (const auto& n : run.notes) derived = derived || n.find("3 fragment sites that run exactly once") != std::string::npos;
      EXPECT_EQ(derived, label.rfind("accumulate", 0) == 0) << where;
    });
  }
}

TEST(LongLoop, SeventyThousandLoadsPerInvocationCountExactly) {
  std::string why;
  const gpu::Context* ctx = deviceOrSkip(why);
  ASSERT_NE(ctx, nullptr) << why;
  constexpr uint32_t w = 13, h = 9;  // 117 invocations in bounds of 16 x 16 launched
  constexpr uint64_t kLoads = 70008;  // long_loop.comp.glsl
  ComputePass pass(*ctx, w, h, "long_loop.comp.glsl");
  // Derived, the loop adds its 17502 trips once and the loads are host
  // arithmetic; not derived, each load adds in the shader and one register
  // reaches 70008, both halves of the flush's reduction non-zero.
  for (bool derive : {true, false}) {
    for (const auto& [mode, width] : exactModes(*ctx)) {
      auto run = pass.run({mode, width, 1, {}, 0, derive});
      ASSERT_TRUE(run.ok()) << run.error();
      const std::string where = modeLabel(mode, width) + (derive ? "" : " not derived");
      EXPECT_EQ(sumKind(run->sites, run->counters, SiteKind::BufferRead, Stage::Compute), uint64_t(w) * h * kLoads)
          << where;
      EXPECT_EQ(sumKind(run->sites, run->counters, SiteKind::BufferWrite, Stage::Compute), uint64_t(w) * h) << where;
      EXPECT_EQ(sumKind(run->sites, run->counters, SiteKind::Invocation, Stage::Compute), 16u * 16u) << where;
    }
  }
}

// Compute counters striped over 16 copies (chosen by workgroup and subgroup
// or lane) fold to the very counts of one copy, in every slot; and the
// copies are in use, so striping is live and not a no-op.
//  - mixed_reads at 157 x 91 (20 x 12 workgroups: x + 3y alone covers every
//    copy) has no loop: with a per-lane flush every site runs once and is
//    counted per access, so nothing is flushed and nothing striped;
//  - long_loop at 13 x 9 (4 workgroups) accumulates in every flush.
TEST(StripedCopies, FoldToTheCountsOfOneCopy) {
  std::string why;
  const gpu::Context* ctx = deviceOrSkip(why);
  ASSERT_NE(ctx, nullptr) << why;
  ComputePass mixed(*ctx, 157, 91);
  ComputePass loop(*ctx, 13, 9, "long_loop.comp.glsl");
  const CounterWidth width = ctx->int64Atomics ? CounterWidth::Int64 : CounterWidth::Uint32Pair;
  for (const char* name : {"accumulate", "accumulate:subgroup", "accumulate:lane"}) {
    auto mode = spirv::parseMode(name);
    ASSERT_TRUE(mode.ok());
    const bool lane = std::string(name) == "accumulate:lane";
    for (ComputePass* pass : {&mixed, &loop}) {
      const std::string where = std::string(name) + (pass == &mixed ? " mixed_reads" : " long_loop");
      auto striped = pass->run({*mode, width, 1, {}, 16});
      auto single = pass->run({*mode, width, 1, {}, 1});
      ASSERT_TRUE(striped.ok()) << striped.error();
      ASSERT_TRUE(single.ok()) << single.error();
      if (pass == &mixed) {
        EXPECT_EQ(striped->copiesWritten, lane ? 0u : 16u) << where;
      } else {
        EXPECT_GT(striped->copiesWritten, 1u) << where;
      }
      EXPECT_EQ(single->copiesWritten, 0u) << where << ": one copy is not striped";
      ASSERT_EQ(striped->sites.size(), single->sites.size());
      for (const auto& s : single->sites) {
        for (uint32_t i = 0; i < s.slotCount; ++i) {
          EXPECT_EQ(striped->counters.at(s.slot + i), single->counters.at(s.slot + i))
              << where << ": slot " << s.slot + i << " (" << s.resource << ")";
        }
      }
      EXPECT_GT(sumKind(single->sites, single->counters, SiteKind::BufferRead, Stage::Compute), 0u) << where;
    }
  }
}

// A descriptor array longer than the registers hold: each element's count,
// from both sites, against the same sum done here over the in-bounds
// invocations (cached_arrays.comp.glsl's header). At 37 x 21 the 5 x 3
// workgroups' edges are partial, so flushes run with fewer lanes than a
// subgroup, and both caches change elements within one invocation.
TEST(CachedArrays, EveryElementCountsAsByHand) {
  std::string why;
  const gpu::Context* ctx = deviceOrSkip(why);
  ASSERT_NE(ctx, nullptr) << why;
  constexpr uint32_t w = 37, h = 21;
  std::array<uint64_t, kComputeBufferArray> expected{};
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      const uint32_t gx = x / kComputeWorkgroupSize, gy = y / kComputeWorkgroupSize;
      for (uint32_t i = 0; i < 9; ++i) {
        ++expected[(gx + gy + i / 3) % kComputeBufferArray];
        ++expected[(2 * gx + i) % kComputeBufferArray];
      }
    }
  }
  ComputePass pass(*ctx, w, h, "cached_arrays.comp.glsl");
  forEachExactMode(*ctx, pass, [&](const PassRun& run, const std::string& where) {
    std::set<uint32_t> bases;  // the two sites may share their resource's slots
    for (const auto& s : run.sites) {
      if (s.kind == SiteKind::BufferRead && s.slotCount == kComputeBufferArray) bases.insert(s.slot);
    }
    ASSERT_FALSE(bases.empty()) << where << ": no site reads the array";
    for (uint32_t e = 0; e < kComputeBufferArray; ++e) {
      uint64_t counted = 0;
      for (uint32_t base : bases) counted += run.counters.at(base + e);
      EXPECT_EQ(counted, expected[e]) << where << ": element " << e;
    }
    EXPECT_EQ(sumKind(run.sites, run.counters, SiteKind::BufferWrite, Stage::Compute), uint64_t(w) * h) << where;
    // Where compute has subgroup arithmetic the reads go through the caches, not an atomic each.
    if (where.starts_with("accumulate") && (ctx->subgroupStages & spirv::stageBit(Stage::Compute)) != 0) {
      for (const auto& note : run.notes) EXPECT_EQ(note.find("descriptor arrays of more than"), std::string::npos) << where << ": " << note;
    }
  });
}

}  // namespace
}  // namespace tally::test

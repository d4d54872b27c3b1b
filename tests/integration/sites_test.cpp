// Per-site counts (InstrumentOptions::perSite) against counts derived by
// hand in the shaders' headers, per source line, in every exact mode on the
// device: a read outside any loop, in a loop of fixed trip count, in a loop
// whose trip count varies per invocation, and on a branch; for the fragment,
// vertex and compute stages. And each resource's sum over its sites equals
// the count of the same pass counted without per-site slots.
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gpu_fixture.hpp"
#include "passes.hpp"

namespace tally::test {
namespace {

using spirv::SiteKind;
using spirv::Stage;

// The line (1-based) of `file` in the integration shaders that carries `// [tag]`.
uint32_t markedLine(const std::string& file, const std::string& tag) {
  std::ifstream in(shaderDir() + "/" + file);
  std::string text;
  uint32_t number = 0;
  while (std::getline(in, text)) {
    ++number;
    if (text.find("// [" + tag + "]") != std::string::npos) return number;
  }
  ADD_FAILURE() << file << " has no line marked [" << tag << "]";
  return 0;
}

uint64_t siteCount(const PassRun& run, const spirv::Site& site) {
  uint64_t n = 0;
  for (uint32_t i = 0; i < std::max(site.slotCount, 1u); ++i) {
    if (site.slot + i < run.counters.size()) n += run.counters[site.slot + i];
  }
  return n;
}

// Every access site of `stage` on `line` of `file`: there is exactly one, and its count.
uint64_t countOnLine(const PassRun& run, Stage stage, const std::string& file, uint32_t line, const std::string& where) {
  const spirv::Site* found = nullptr;
  int sites = 0;
  for (const auto& s : run.sites) {
    if (s.stage != stage || s.kind == SiteKind::Invocation || s.kind == SiteKind::OutputWrite) continue;
    if (s.line != line || s.file.find(file) == std::string::npos) continue;
    found = &s;
    ++sites;
  }
  EXPECT_EQ(sites, 1) << where << ": sites on " << file << ":" << line;
  return found != nullptr ? siteCount(run, *found) : 0;
}

// Per resource and kind: the sum over the resource's sites of `stage`.
std::map<std::string, uint64_t> perResource(const PassRun& run, Stage stage) {
  std::map<std::string, uint64_t> out;
  std::map<uint32_t, bool> seen;  // shared slots (per-site off) count once
  for (const auto& s : run.sites) {
    if (s.stage != stage || seen[s.slot]) continue;
    seen[s.slot] = true;
    out[s.resource + "/" + std::string(spirv::toString(s.kind))] += siteCount(run, s);
  }
  return out;
}

// Every access site of a per-site run has its own slots, an instruction and its text.
void expectDescribed(const PassRun& run, const std::string& where) {
  std::map<uint32_t, int> owners;
  for (const auto& s : run.sites) {
    if (s.kind == SiteKind::Invocation) continue;
    ++owners[s.slot];
    EXPECT_FALSE(s.disassembly.empty()) << where << ": site at slot " << s.slot;
    EXPECT_NE(s.disassembly.find(s.kind == SiteKind::OutputWrite ? "OpStore" : s.opcode), std::string::npos)
        << where << ": " << s.disassembly;
    EXPECT_EQ(s.function, "main") << where;
  }
  for (const auto& [slot, n] : owners) EXPECT_EQ(n, 1) << where << ": slot " << slot << " shared";
}

template <class Pass, class Check>
void forEachExactModePerSite(const gpu::Context& ctx, Pass& pass, Stage stage, Check check) {
  for (const auto& [mode, width] : exactModes(ctx)) {
    const std::string where = modeLabel(mode, width);
    RunOptions perSite{mode, width, 1};
    perSite.perSite = true;
    auto sites = pass.run(perSite);
    ASSERT_TRUE(sites.ok()) << where << ": " << sites.error();
    auto shared = pass.run({mode, width, 1});
    ASSERT_TRUE(shared.ok()) << where << ": " << shared.error();
    expectDescribed(*sites, where);
    EXPECT_EQ(perResource(*sites, stage), perResource(*shared, stage)) << where;
    check(*sites, where);
  }
}

TEST(SitesPerLine, FragmentReadsInAndOutOfLoopsCountAsDerivedByHand) {
  std::string why;
  const gpu::Context* ctx = testContext(&why);
  ASSERT_NE(ctx, nullptr) << why;
  const std::string file = "sites_loop.frag.glsl";
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{157, 91}, {64, 33}}) {
    FragmentPass pass(*ctx, w, h, std::nullopt, file);
    uint64_t varied = 0;
    for (uint32_t x = 0; x < w; ++x) varied += uint64_t(x % 4) * h;
    const uint64_t all = uint64_t(w) * h, even = uint64_t((w + 1) / 2) * h;
    forEachExactModePerSite(*ctx, pass, Stage::Fragment, [&](const PassRun& run, const std::string& mode) {
      const std::string where = std::to_string(w) + "x" + std::to_string(h) + " " + mode;
      EXPECT_EQ(countOnLine(run, Stage::Fragment, file, markedLine(file, "once"), where), all) << where;
      EXPECT_EQ(countOnLine(run, Stage::Fragment, file, markedLine(file, "fixed"), where), 3 * all) << where;
      EXPECT_EQ(countOnLine(run, Stage::Fragment, file, markedLine(file, "varied"), where), varied) << where;
      EXPECT_EQ(countOnLine(run, Stage::Fragment, file, markedLine(file, "branch"), where), even) << where;
      EXPECT_EQ(countOnLine(run, Stage::Fragment, file, markedLine(file, "merge"), where), all) << where;
    });
  }
}

TEST(SitesPerLine, VertexReadsInAndOutOfLoopsCountAsDerivedByHand) {
  std::string why;
  const gpu::Context* ctx = testContext(&why);
  ASSERT_NE(ctx, nullptr) << why;
  const std::string file = "sites_loop.vert.glsl";
  FragmentPass pass(*ctx, 64, 48, std::nullopt, "five_reads.frag.glsl", file);
  forEachExactModePerSite(*ctx, pass, Stage::Vertex, [&](const PassRun& run, const std::string& where) {
    // One triangle: three vertex invocations (the pipeline statistic says so too).
    EXPECT_EQ(run.statistics.vertexShaderInvocations, 3u) << where;
    EXPECT_EQ(countOnLine(run, Stage::Vertex, file, markedLine(file, "once"), where), 3u) << where;
    EXPECT_EQ(countOnLine(run, Stage::Vertex, file, markedLine(file, "fixed"), where), 12u) << where;
    EXPECT_EQ(countOnLine(run, Stage::Vertex, file, markedLine(file, "varied"), where), 0u + 1u + 2u) << where;
  });
}

TEST(SitesPerLine, ComputeAccessesInAndOutOfLoopsCountAsDerivedByHand) {
  std::string why;
  const gpu::Context* ctx = testContext(&why);
  ASSERT_NE(ctx, nullptr) << why;
  const std::string file = "sites_loop.comp.glsl";
  constexpr uint32_t w = 45, h = 29;  // not multiples of the 8x8 workgroup
  ComputePass pass(*ctx, w, h, file);
  uint64_t varied = 0;
  for (uint32_t x = 0; x < w; ++x) varied += uint64_t(x % 3) * h;
  const uint64_t all = uint64_t(w) * h;
  forEachExactModePerSite(*ctx, pass, Stage::Compute, [&](const PassRun& run, const std::string& where) {
    EXPECT_EQ(countOnLine(run, Stage::Compute, file, markedLine(file, "once"), where), all) << where;
    EXPECT_EQ(countOnLine(run, Stage::Compute, file, markedLine(file, "fixed"), where), 4 * all) << where;
    EXPECT_EQ(countOnLine(run, Stage::Compute, file, markedLine(file, "varied"), where), varied) << where;
    EXPECT_EQ(countOnLine(run, Stage::Compute, file, markedLine(file, "store"), where), all) << where;
  });
}

}  // namespace
}  // namespace tally::test

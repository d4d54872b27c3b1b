// Counter overflow on a real Vulkan device (docs/measurement.md, "Counter
// overflow"): every slot starts just below a multiple of 2^32, so a pass of a
// few thousand accesses per slot carries each slot's low word across the
// 32-bit boundary without running 4 billion atomics.
//
// - int64 and uint32_pair must both end at exactly start + count, where count
//   is what the same pass counts from zero (and, in exact modes, the analytic
//   count): the carry lands in the high word once per wrapped slot;
// - the low word alone (what a plain 32-bit counter would hold) must have
//   wrapped in every slot that received more than its headroom, and reads
//   2^32 less than the true value there;
// - sampled:N adds N at a time, and the headroom is odd, so the add that wraps
//   a slot always straddles 2^32 rather than landing on it; subgroup mode adds
//   a lane count, accumulate a subgroup's total (its high and low 16 bits
//   added as one 64-bit amount). All must carry exactly as exact mode does.
#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <ostream>
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

constexpr uint64_t kTwo32 = uint64_t(1) << 32;
// The size of both passes: 14,287 pixels (compute: invocations inside the
// grid), so every fragment or compute slot receives at least 14,287 counts,
// far more than the headroom below.
constexpr uint32_t kWidth = 157, kHeight = 91;

// Slot i starts at (i + 1) * 2^32 - headroom(i): a high word of i, a low word
// headroom(i) below the wrap. The headroom is odd (never a multiple of a
// sampled mode's even N) and below the smallest per-slot count of the
// fragment and compute stages (14,287), above the vertex stage's (3, or one
// sampled tile's N <= 64).
uint64_t headroom(size_t slot) { return 1001 + 2 * uint64_t(slot); }
uint64_t startValue(size_t slot) { return (uint64_t(slot) + 1) * kTwo32 - headroom(slot); }

uint32_t low32(uint64_t v) { return uint32_t(v); }
uint32_t high32(uint64_t v) { return uint32_t(v >> 32); }

struct OverflowCase {
  const char* pass;  // "fragment" or "compute"
  const char* mode;
  CounterWidth width;
};

void PrintTo(const OverflowCase& c, std::ostream* os) {
  *os << c.pass << " " << c.mode << (c.width == CounterWidth::Uint32Pair ? "/uint32_pair" : "/int64");
}

std::string caseName(const ::testing::TestParamInfo<OverflowCase>& info) {
  std::string name = std::string(info.param.pass) + "_" + info.param.mode +
                     (info.param.width == CounterWidth::Uint32Pair ? "_uint32_pair" : "_int64");
  for (char& c : name) {
    if (c == ':') c = '_';
  }
  return name;
}

// Stage of each slot, from the site table.
std::vector<Stage> slotStages(const std::vector<spirv::Site>& sites, size_t slots) {
  std::vector<Stage> stages(slots, Stage::Other);
  for (const auto& s : sites) {
    for (uint32_t i = 0; i < std::max(s.slotCount, 1u); ++i) {
      if (s.slot + i < slots) stages[s.slot + i] = s.stage;
    }
  }
  return stages;
}

template <class Pass>
void checkWrap(Pass& pass, const OverflowCase& c, Stage countedStage) {
  auto mode = spirv::parseMode(c.mode);
  ASSERT_TRUE(mode.ok()) << mode.error();

  // The same pass from zero: what each slot receives.
  // One copy of each compute counter, so that every slot's flush carries
  // across the wrap (striped copies would each receive a sixteenth). Every
  // site adds in the shader: a site derived from the invocation count
  // (accumulate) adds nothing there, and its count is host arithmetic on
  // 64-bit values, which starts from zero.
  auto fromZero = pass.run({*mode, c.width, 1, {}, 1, false});
  ASSERT_TRUE(fromZero.ok()) << fromZero.error();
  const size_t slots = fromZero->counters.size();
  ASSERT_GT(slots, 0u);

  std::vector<uint64_t> start(slots);
  for (size_t i = 0; i < slots; ++i) start[i] = startValue(i);
  auto wrapped = pass.run({*mode, c.width, 1, start, 1, false});
  ASSERT_TRUE(wrapped.ok()) << wrapped.error();
  ASSERT_EQ(wrapped->counters.size(), slots);

  const std::vector<Stage> stages = slotStages(fromZero->sites, slots);
  std::vector<uint64_t> received(slots);
  size_t wrappedSlots = 0, countedSlots = 0;
  for (size_t i = 0; i < slots; ++i) {
    const uint64_t n = fromZero->counters[i];
    const uint64_t end = wrapped->counters[i];
    received[i] = end - start[i];
    // The whole 64-bit value: exactly start + n, in both widths.
    EXPECT_EQ(end, start[i] + n) << "slot " << i << ": started at " << start[i] << ", received " << n;

    const bool isCounted = stages[i] == countedStage;
    countedSlots += isCounted ? 1 : 0;
    if (n >= headroom(i)) {
      ++wrappedSlots;
      // One carry into the high word...
      EXPECT_EQ(high32(end), high32(start[i]) + 1) << "slot " << i;
      // ...which a plain 32-bit counter would have lost: its value went down,
      // and reads exactly 2^32 less than the count.
      EXPECT_LT(low32(end), low32(start[i])) << "slot " << i;
      EXPECT_EQ(uint64_t(low32(end)) + kTwo32, uint64_t(low32(start[i])) + n) << "slot " << i;
    } else {
      EXPECT_EQ(high32(end), high32(start[i])) << "slot " << i << " received " << n << ", no wrap";
    }
    // Derived from the pass: every slot of the counted stage receives at least
    // 14,287 counts, more than any headroom; the vertex slots fewer.
    if (isCounted) {
      EXPECT_GE(n, headroom(i)) << "slot " << i << " of the counted stage must wrap";
    }
  }
  EXPECT_GE(countedSlots, 4u) << "the pass instruments fewer slots than its shader has resources";
  EXPECT_EQ(wrappedSlots, countedSlots);

  // In exact modes the counts across the wrap are the analytic ones.
  if (mode->kind != spirv::CountMode::Sampled) {
    const uint64_t inside = uint64_t(kWidth) * kHeight;
    const uint64_t reads = countedStage == Stage::Fragment ? kFragmentReads : kComputeTextureReads;
    EXPECT_EQ(sumKind(fromZero->sites, received, SiteKind::TextureRead, countedStage), inside * reads);
  }

  std::printf("[overflow %s %s/%s] %zu slots, %zu wrapped their low word; e.g. slot 0: start %" PRIu64
              " + %" PRIu64 " = %" PRIu64 " (low word alone: %u)\n",
              c.pass, c.mode, c.width == CounterWidth::Uint32Pair ? "uint32_pair" : "int64", slots,
              wrappedSlots, start[0], fromZero->counters[0], wrapped->counters[0],
              low32(wrapped->counters[0]));
  appendStatsLine({{"test", "CounterOverflow"},
                   {"pass", c.pass},
                   {"mode", modeLabel(*mode, c.width)},
                   {"slots", slots},
                   {"wrapped_slots", wrappedSlots}});
}

class CounterOverflow : public ::testing::TestWithParam<OverflowCase> {};

TEST_P(CounterOverflow, CarriesAcrossTwoTo32) {
  std::string error;
  const gpu::Context* ctx = testContext(&error);
  ASSERT_NE(ctx, nullptr) << error;
  const OverflowCase& c = GetParam();
  if (c.width == CounterWidth::Int64 && !ctx->int64Atomics) {
    GTEST_SKIP() << "device has no shaderBufferInt64Atomics";
  }
  if (std::string(c.pass) == "fragment") {
    FragmentPass pass(*ctx, kWidth, kHeight);
    checkWrap(pass, c, Stage::Fragment);
  } else {
    ComputePass pass(*ctx, kWidth, kHeight);
    checkWrap(pass, c, Stage::Compute);
  }
}

std::vector<OverflowCase> overflowCases() {
  std::vector<OverflowCase> cases;
  for (const char* pass : {"fragment", "compute"}) {
    for (const char* mode : {"exact", "subgroup", "sampled:4", "sampled:16", "sampled:64", "accumulate", "accumulate:subgroup", "accumulate:lane"}) {
      cases.push_back({pass, mode, CounterWidth::Uint32Pair});
    }
    cases.push_back({pass, "exact", CounterWidth::Int64});
    cases.push_back({pass, "accumulate", CounterWidth::Int64});
    cases.push_back({pass, "sampled:16", CounterWidth::Int64});
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Widths, CounterOverflow, ::testing::ValuesIn(overflowCases()), caseName);

}  // namespace
}  // namespace tally::test

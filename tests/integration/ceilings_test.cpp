// Device ceilings (gpu/ceilings.hpp) on the test device: positive, sized as
// documented, and the copy's bandwidth within an order of magnitude of a
// host memcpy of the same size timed here (on lavapipe both run on the same
// memory; the ratio, not a time, is asserted).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "gpu/ceilings.hpp"
#include "gpu_fixture.hpp"

namespace tally {
namespace {

// Bytes read + written per second by the fastest of `repetitions` memcpys of `bytes`.
double hostCopyBandwidth(size_t bytes, int repetitions) {
  std::vector<char> from(bytes, 1), to(bytes, 0);
  double best = 1e30;
  for (int r = 0; r < repetitions; ++r) {
    from[size_t(r) % bytes] = char(r);
    auto started = std::chrono::steady_clock::now();
    std::memcpy(to.data(), from.data(), bytes);
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  }
  EXPECT_EQ(to[bytes / 2], from[bytes / 2]);
  return 2.0 * double(bytes) / best;
}

TEST(Ceilings, PositiveAndPlausibleAgainstAHostCopy) {
  std::string why;
  const gpu::Context* ctx = test::testContext(&why);
  if (ctx == nullptr) GTEST_SKIP() << why;
  auto ceilings = gpu::measureCeilings(*ctx, TALLY_RENDERER_SHADER_DIR);
  ASSERT_TRUE(ceilings.ok()) << ceilings.error();
  const gpu::Ceilings& c = *ceilings;

  EXPECT_EQ(c.copyBytes, gpu::copyBytesFor(*ctx));
  if (ctx->properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    EXPECT_EQ(c.copyBytes, 64ull << 20);
  }
  EXPECT_EQ(c.repetitions, 5u);
  EXPECT_GT(c.copySeconds, 0.0);
  EXPECT_DOUBLE_EQ(c.bandwidthBytesPerS, 2.0 * double(c.copyBytes) / c.copySeconds);
  // 64 operations per iteration: 8 chains x 4 components x (multiply + add).
  EXPECT_EQ(c.arithmeticOps, uint64_t(c.fmaInvocations) * c.fmaIterations * 64u);
  EXPECT_GT(c.arithmeticSeconds, 0.0);
  EXPECT_DOUBLE_EQ(c.arithmeticOpsPerS, double(c.arithmeticOps) / c.arithmeticSeconds);
  EXPECT_GT(c.arithmeticOpsPerS, 1e8);  // any device, a CPU core included, does 100 Mop/s

  double host = hostCopyBandwidth(size_t(c.copyBytes), 5);
  double ratio = c.bandwidthBytesPerS / host;
  std::printf("ceilings: copy %.2f GB/s, host memcpy %.2f GB/s (ratio %.2f), arithmetic %.2f Gop/s, %.3f s\n",
              c.bandwidthBytesPerS * 1e-9, host * 1e-9, ratio, c.arithmeticOpsPerS * 1e-9, c.measureSeconds);
  if (ctx->properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
    EXPECT_GT(ratio, 0.1);
    EXPECT_LT(ratio, 10.0);
  } else {
    EXPECT_GT(ratio, 0.1);  // a GPU's memory is not slower than a tenth of the host's
  }

  auto j = gpu::toJson(c);
  for (const char* key : {"bandwidth_bytes_per_s", "arithmetic_ops_per_s", "ridge_intensity", "copy_bytes"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_DOUBLE_EQ(j["ridge_intensity"].get<double>(), c.arithmeticOpsPerS / c.bandwidthBytesPerS);
  EXPECT_EQ(j["method"]["timing"], ctx->timestamps ? "timestamps" : "host");
}

TEST(Ceilings, AGivenCopySizeIsUsedAndAMissingShaderIsAnError) {
  std::string why;
  const gpu::Context* ctx = test::testContext(&why);
  if (ctx == nullptr) GTEST_SKIP() << why;
  gpu::CeilingOptions options;
  options.copyBytes = (1u << 20) + 7;  // rounded down to whole 16-byte elements
  options.repetitions = 2;
  auto small = gpu::measureCeilings(*ctx, TALLY_RENDERER_SHADER_DIR, options);
  ASSERT_TRUE(small.ok()) << small.error();
  EXPECT_EQ(small->copyBytes, 1u << 20);
  EXPECT_EQ(small->repetitions, 2u);
  auto missing = gpu::measureCeilings(*ctx, "/nonexistent");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("ceiling_copy.comp.glsl"), std::string::npos) << missing.error();
}

}  // namespace
}  // namespace tally

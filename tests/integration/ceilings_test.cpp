// Device ceilings (gpu/ceilings.hpp) on the test device: positive, finite,
// sized as documented, and the copy really copied (the measurement reads back
// the destination). How fast the copy is against a host memcpy is a figure,
// not a check: tally_bench_ceilings prints it (docs/benchmarks.md).
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "strict.hpp"

#include "gpu/ceilings.hpp"
#include "gpu_fixture.hpp"

namespace tally {
namespace {

TEST(Ceilings, PositiveFiniteAndTheCopyIsCorrect) {
  std::string why;
  const gpu::Context* ctx = test::testContext(&why);
  if (ctx == nullptr) TALLY_SKIP_UNLESS_STRICT(why);
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
  EXPECT_TRUE(std::isfinite(c.bandwidthBytesPerS) && c.bandwidthBytesPerS > 0) << c.bandwidthBytesPerS;
  EXPECT_TRUE(std::isfinite(c.arithmeticOpsPerS) && c.arithmeticOpsPerS > 0) << c.arithmeticOpsPerS;
  // Three 64 KiB windows of the destination (start, middle, end) were read
  // back and held the source's pattern (else measureCeilings fails).
  EXPECT_EQ(c.copyVerifiedBytes, 3u * 64u * 1024u);
  std::printf("ceilings: copy %.2f GB/s, arithmetic %.2f Gop/s, %.3f s\n", c.bandwidthBytesPerS * 1e-9,
              c.arithmeticOpsPerS * 1e-9, c.measureSeconds);

  auto j = gpu::toJson(c);
  for (const char* key : {"bandwidth_bytes_per_s", "arithmetic_ops_per_s", "ridge_intensity", "copy_bytes"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["method"]["copy_verified_bytes"], c.copyVerifiedBytes);
  EXPECT_DOUBLE_EQ(j["ridge_intensity"].get<double>(), c.arithmeticOpsPerS / c.bandwidthBytesPerS);
  EXPECT_EQ(j["method"]["timing"], ctx->timestamps ? "timestamps" : "host");
}

TEST(Ceilings, AGivenCopySizeIsUsedAndAMissingShaderIsAnError) {
  std::string why;
  const gpu::Context* ctx = test::testContext(&why);
  if (ctx == nullptr) TALLY_SKIP_UNLESS_STRICT(why);
  gpu::CeilingOptions options;
  options.copyBytes = (1u << 20) + 7;  // rounded down to whole 16-byte elements
  options.repetitions = 2;
  auto small = gpu::measureCeilings(*ctx, TALLY_RENDERER_SHADER_DIR, options);
  ASSERT_TRUE(small.ok()) << small.error();
  EXPECT_EQ(small->copyBytes, 1u << 20);
  EXPECT_EQ(small->repetitions, 2u);
  EXPECT_EQ(small->copyVerifiedBytes, 3u * 64u * 1024u);
  auto missing = gpu::measureCeilings(*ctx, "/nonexistent");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("ceiling_copy.comp.glsl"), std::string::npos) << missing.error();
}

}  // namespace
}  // namespace tally

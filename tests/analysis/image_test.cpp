// Image error and spreads against values worked out by hand.
#include <cmath>

#include <gtest/gtest.h>

#include "analysis/image.hpp"
#include "analysis/stats.hpp"

namespace tally::analysis {
namespace {

TEST(ImageError, IdenticalImagesHaveInfinitePsnr) {
  std::vector<uint8_t> a(4 * 4 * 4, 77);
  auto e = compareImages(a, a, 4, 4);
  ASSERT_TRUE(e.ok());
  EXPECT_TRUE(std::isinf(e->psnr));
  EXPECT_EQ(e->maxAbs, 0);
}

TEST(ImageError, OneChannelOffByTen) {
  // 2x1 image, one of 6 RGB samples differs by 10: MSE = 100/6,
  // PSNR = 10 log10(255^2 / (100/6)) = 35.917 dB. Alpha differences are ignored.
  std::vector<uint8_t> a = {10, 20, 30, 255, 40, 50, 60, 255};
  std::vector<uint8_t> b = {10, 20, 40, 0, 40, 50, 60, 255};
  auto e = compareImages(a, b, 2, 1);
  ASSERT_TRUE(e.ok());
  EXPECT_NEAR(e->psnr, 10.0 * std::log10(255.0 * 255.0 / (100.0 / 6.0)), 1e-9);
  EXPECT_NEAR(e->psnr, 35.9123, 1e-4);
  EXPECT_EQ(e->maxAbs, 10);
  EXPECT_NEAR(e->meanAbs, 10.0 / 6.0, 1e-12);
}

TEST(ImageError, SizeMismatchIsAnError) {
  std::vector<uint8_t> a(16), b(12);
  auto e = compareImages(a, b, 2, 2);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().find("differ in size"), std::string::npos);
}

TEST(Png, EncodesASignatureAndTheSize) {
  std::vector<uint8_t> rgba(3 * 2 * 4, 200);
  auto png = encodePng(rgba, 3, 2);
  ASSERT_GT(png.size(), 33u);
  const uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_TRUE(std::equal(signature, signature + 8, png.begin()));
  // IHDR width and height, big-endian, at bytes 16..23.
  EXPECT_EQ(png[19], 3);
  EXPECT_EQ(png[23], 2);
}

TEST(Spread, QuartilesByInterpolation) {
  auto s = spreadOf({5, 1, 4, 2, 3});
  EXPECT_DOUBLE_EQ(s.median, 3);
  EXPECT_DOUBLE_EQ(s.q1, 2);
  EXPECT_DOUBLE_EQ(s.q3, 4);
  EXPECT_DOUBLE_EQ(s.iqr(), 2);
  EXPECT_DOUBLE_EQ(s.mean, 3);
  auto even = spreadOf({1, 2, 3, 4});
  EXPECT_DOUBLE_EQ(even.median, 2.5);
  EXPECT_DOUBLE_EQ(even.q1, 1.75);
  EXPECT_EQ(spreadOf({}).n, 0u);
}

}  // namespace
}  // namespace tally::analysis

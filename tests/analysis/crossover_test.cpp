// Crossover fits on synthetic series of known fixed and per-pixel cost plus
// Gaussian noise (fixed seeds): the t intervals of a and b cover the true
// values at about the nominal rate, crossings are found where they were
// built, and the "outside the range", parallel and degenerate cases.
#include "analysis/crossover.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace {
using namespace tally::analysis;

// Ten 16:9 resolutions from 640x360 to 3840x2160.
std::vector<double> sweepPixels() {
  std::vector<double> p;
  for (int i = 0; i < 10; ++i) {
    int h = 360 + i * 200;  // 360 .. 2160
    p.push_back(double(h) * std::round(h * 16.0 / 9.0));
  }
  return p;
}

std::vector<double> line(const std::vector<double>& x, double a, double b, double sigma, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<double> y;
  for (double v : x) y.push_back(a + b * v + (sigma > 0 ? noise(rng) : 0.0));
  return y;
}

TEST(CrossoverFit, ExactLineIsRecovered) {
  auto x = sweepPixels();
  std::mt19937_64 rng(1);
  auto fit = fitLinear(x, line(x, 3e6, 24.0, 0, rng));
  ASSERT_TRUE(fit) << fit.error();
  EXPECT_NEAR(fit->a, 3e6, 1e-3);
  EXPECT_NEAR(fit->b, 24.0, 1e-9);
  EXPECT_NEAR(fit->r2, 1.0, 1e-12);
  EXPECT_FALSE(fit->poor);
  ASSERT_EQ(fit->points.size(), x.size());
  for (const auto& p : fit->points) EXPECT_NEAR(p.residual, 0.0, 1e-3);
  EXPECT_EQ(fit->minPixels, x.front());
  EXPECT_EQ(fit->maxPixels, x.back());
}

TEST(CrossoverFit, TQuantileMatchesTables) {
  EXPECT_NEAR(tQuantile(0.95, 8), 2.306004, 1e-6);
  EXPECT_NEAR(tQuantile(0.95, 1), 12.7062, 1e-4);
  EXPECT_NEAR(tQuantile(0.95, 1000), 1.962339, 1e-6);
}

// Over 4000 draws the 95% intervals of a and b each cover the truth between
// 94% and 96% of the time (binomial SE ~0.34%), and the residuals sum to 0.
TEST(CrossoverFit, IntervalsCoverAtTheNominalRate) {
  auto x = sweepPixels();
  std::mt19937_64 rng(20261125);
  const double a = 2.0, b = 1.5e-6, sigma = 0.4;  // ms: 2 ms fixed, 1.5 ms per megapixel
  const int draws = 4000;
  int coverA = 0, coverB = 0;
  for (int d = 0; d < draws; ++d) {
    auto fit = fitLinear(x, line(x, a, b, sigma, rng));
    ASSERT_TRUE(fit) << fit.error();
    coverA += fit->aLow <= a && a <= fit->aHigh;
    coverB += fit->bLow <= b && b <= fit->bHigh;
    if (d == 0) {
      double sum = 0;
      for (const auto& p : fit->points) sum += p.residual;
      EXPECT_NEAR(sum, 0.0, 1e-9);
    }
  }
  EXPECT_NEAR(double(coverA) / draws, 0.95, 0.01) << coverA;
  EXPECT_NEAR(double(coverB) / draws, 0.95, 0.01) << coverB;
}

TEST(CrossoverFit, PoorFitIsFlagged) {
  // Quadratic growth with a flat start: the line leaves a bow in the residuals and r2 < 0.9.
  std::vector<double> x = {1, 2, 3, 4, 5, 6, 7, 8};
  std::vector<double> y = {5, 1, 0, 1, 5, 1, 0, 1};
  auto fit = fitLinear(x, y);
  ASSERT_TRUE(fit) << fit.error();
  EXPECT_LT(fit->r2, kPoorFitR2);
  EXPECT_TRUE(fit->poor);
  EXPECT_EQ(toJson(*fit)["poor_fit"], true);
}

TEST(CrossoverFit, DegenerateInputsAreErrors) {
  auto two = fitLinear({1e5, 2e5}, {1, 2});
  ASSERT_FALSE(two);
  EXPECT_NE(two.error().find("at least 3 resolutions"), std::string::npos) << two.error();
  auto none = fitLinear({}, {});
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().find("at least 3 resolutions, got 0"), std::string::npos) << none.error();
  auto same = fitLinear({921600, 921600, 921600}, {1, 2, 3});
  ASSERT_FALSE(same);
  EXPECT_NE(same.error().find("same pixel count (921600)"), std::string::npos) << same.error();
  auto sizes = fitLinear({1, 2, 3}, {1, 2});
  ASSERT_FALSE(sizes);
  EXPECT_NE(sizes.error().find("differ in number"), std::string::npos) << sizes.error();
  auto nan = fitLinear({1, 2, 3}, {1, NAN, 3});
  ASSERT_FALSE(nan);
  EXPECT_NE(nan.error().find("not a finite number"), std::string::npos) << nan.error();
}

// Deferred-like: small fixed cost, large per-pixel cost; visbuffer-like: a
// larger fixed cost (the triangle pass) and a smaller per-pixel cost. They
// cross at (a2 - a1) / (b1 - b2) = (9e6 - 1e6) / (40 - 30) = 800,000 pixels.
TEST(CrossoverCrossing, FoundWhereConstructed) {
  auto x = sweepPixels();
  std::mt19937_64 rng(7);
  auto deferred = fitLinear(x, line(x, 1e6, 40.0, 2e5, rng));
  auto visbuffer = fitLinear(x, line(x, 9e6, 30.0, 2e5, rng));
  ASSERT_TRUE(deferred && visbuffer);
  Crossing c = crossing(*deferred, *visbuffer);
  ASSERT_EQ(c.kind, CrossingKind::Crosses);
  ASSERT_TRUE(c.pixels && c.low && c.high);
  EXPECT_NEAR(*c.pixels, 800000, 40000);
  EXPECT_LE(*c.low, 800000);
  EXPECT_GE(*c.high, 800000);
  EXPECT_LT(*c.low, *c.pixels);
  EXPECT_GT(*c.high, *c.pixels);
  EXPECT_EQ(c.lowerBelow, 0);  // deferred below the crossing
  EXPECT_EQ(c.lowerAbove, 1);  // visbuffer above it
  EXPECT_EQ(c.degreesOfFreedom, 16);
  nlohmann::json j = toJson(c, "deferred", "visbuffer");
  EXPECT_EQ(j["kind"], "crosses");
  EXPECT_EQ(j["lower_below"], "deferred");
  EXPECT_EQ(j["lower_above"], "visbuffer");
  EXPECT_TRUE(j["lower_throughout"].is_null());
  EXPECT_EQ(j["interval_method"], "delta");
  // About 1193x671 at 16:9.
  auto r = resolution169(800000);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->height, 671);
  EXPECT_EQ(r->width, 1193);
  EXPECT_NEAR(double(r->width) * r->height, 800000, 2000);
  // The other order: the same point, the sides swapped.
  Crossing swapped = crossing(*visbuffer, *deferred);
  EXPECT_NEAR(*swapped.pixels, *c.pixels, 1e-6 * *c.pixels);
  EXPECT_NEAR(*swapped.pixelsSe, *c.pixelsSe, 1e-6 * *c.pixelsSe);
  EXPECT_EQ(swapped.lowerBelow, 1);
  EXPECT_EQ(swapped.lowerAbove, 0);
}

// The delta method's interval for the crossing covers the constructed point
// at close to the nominal rate when the crossing is well inside the range.
TEST(CrossoverCrossing, IntervalCoversTheConstructedCrossing) {
  auto x = sweepPixels();
  std::mt19937_64 rng(99);
  // a1 = 1e6, b1 = 40; a2 = 41e6, b2 = 30: crossing at 4,000,000 pixels (2667x1500).
  const double cross = 40e6 / 10.0;
  const int draws = 2000;
  int covered = 0;
  for (int d = 0; d < draws; ++d) {
    auto f1 = fitLinear(x, line(x, 1e6, 40.0, 1e6, rng));
    auto f2 = fitLinear(x, line(x, 41e6, 30.0, 1e6, rng));
    ASSERT_TRUE(f1 && f2);
    Crossing c = crossing(*f1, *f2);
    ASSERT_NE(c.kind, CrossingKind::Parallel);
    covered += *c.low <= cross && cross <= *c.high;
  }
  EXPECT_NEAR(double(covered) / draws, 0.95, 0.02) << covered;
}

TEST(CrossoverCrossing, NoCrossingInTheMeasuredRange) {
  auto x = sweepPixels();
  std::mt19937_64 rng(3);
  // Cross at (2e6 - 1e6) / (40 - 30) = 100,000 pixels, below 640x360: the
  // second is lower throughout the range.
  auto f1 = fitLinear(x, line(x, 1e6, 40.0, 1e5, rng));
  auto f2 = fitLinear(x, line(x, 2e6, 30.0, 1e5, rng));
  ASSERT_TRUE(f1 && f2);
  Crossing c = crossing(*f1, *f2);
  EXPECT_EQ(c.kind, CrossingKind::OutsideRange);
  ASSERT_TRUE(c.pixels);
  EXPECT_LT(*c.pixels, x.front());
  EXPECT_EQ(c.lowerBelow, 1);
  EXPECT_EQ(c.lowerAbove, 1);
  nlohmann::json j = toJson(c, "forward", "deferred");
  EXPECT_EQ(j["kind"], "outside_range");
  EXPECT_EQ(j["lower_throughout"], "deferred");
  EXPECT_TRUE(j["lower_below"].is_null());
  EXPECT_EQ(j["range"][0].get<double>(), x.front());
  EXPECT_EQ(j["range"][1].get<double>(), x.back());
}

TEST(CrossoverCrossing, ParallelWithinError) {
  auto x = sweepPixels();
  std::mt19937_64 rng(5);
  // Equal slopes, intercepts 1 ms apart, noise 0.3 ms.
  auto f1 = fitLinear(x, line(x, 2.0, 1e-6, 0.3, rng));
  auto f2 = fitLinear(x, line(x, 3.0, 1e-6, 0.3, rng));
  ASSERT_TRUE(f1 && f2);
  Crossing c = crossing(*f1, *f2);
  EXPECT_EQ(c.kind, CrossingKind::Parallel);
  EXPECT_FALSE(c.pixels);
  EXPECT_LE(std::abs(c.slopeDifference), tQuantile(0.95, c.degreesOfFreedom) * c.slopeDifferenceSe);
  EXPECT_EQ(c.lowerBelow, 0);
  nlohmann::json j = toJson(c, "forward", "deferred");
  EXPECT_EQ(j["kind"], "parallel");
  EXPECT_TRUE(j["pixels"].is_null());
  EXPECT_TRUE(j["pixels_ci"].is_null());
  EXPECT_TRUE(j["resolution"].is_null());
  EXPECT_EQ(j["lower_throughout"], "forward");
  // Exactly parallel, no noise: parallel too (no division by zero).
  auto e1 = fitLinear(x, line(x, 2.0, 1e-6, 0, rng));
  auto e2 = fitLinear(x, line(x, 3.0, 1e-6, 0, rng));
  EXPECT_EQ(crossing(*e1, *e2).kind, CrossingKind::Parallel);
}

TEST(CrossoverCrossing, Resolution169) {
  auto r = resolution169(1920.0 * 1080.0);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->width, 1920);
  EXPECT_EQ(r->height, 1080);
  EXPECT_FALSE(resolution169(-5));
  EXPECT_FALSE(resolution169(0));
  EXPECT_FALSE(resolution169(NAN));
}

}  // namespace

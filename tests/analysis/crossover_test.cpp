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
  EXPECT_NE(two.error().find("at least 3 resolutions, got 2 ("), std::string::npos) << two.error();
  // Two runs of one resolution are one resolution.
  auto repeated = fitLinear({2e5, 2e5}, {1, 2});
  ASSERT_FALSE(repeated);
  EXPECT_NE(repeated.error().find("at least 3 resolutions, got 1, in 2 runs"), std::string::npos) << repeated.error();
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
  EXPECT_EQ(j["interval_method"], "fieller");
  EXPECT_EQ(j["significant"], true);
  EXPECT_TRUE(j["why"].is_null());
  // Far from the edges both intervals agree closely; the delta one is symmetric.
  ASSERT_TRUE(c.deltaLow && c.deltaHigh);
  EXPECT_NEAR(*c.pixels - *c.deltaLow, *c.deltaHigh - *c.pixels, 1e-6 * *c.pixels);
  EXPECT_NEAR(*c.low, *c.deltaLow, 0.05 * (*c.high - *c.low));
  EXPECT_NEAR(*c.high, *c.deltaHigh, 0.05 * (*c.high - *c.low));
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

// Fieller's interval for the crossing covers the constructed point
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

// Fieller's set found without the quadratic: scan r for the t-statistic
// |N - r D| / sqrt(vN - 2 r c + r^2 vD) crossing t, then bisect each change.
std::vector<double> fiellerEdgesByScan(double n, double d, double vN, double vD, double c, double t, double from,
                                       double to) {
  auto inside = [&](double r) {
    double var = vN - 2 * r * c + r * r * vD;
    return std::abs(n - r * d) <= t * std::sqrt(var);
  };
  std::vector<double> edges;
  const int steps = 200000;
  double prev = from;
  for (int i = 1; i <= steps; ++i) {
    double r = from + (to - from) * i / steps;
    if (inside(r) != inside(prev)) {
      double lo = prev, hi = r;
      for (int k = 0; k < 200; ++k) {
        double mid = (lo + hi) / 2;
        (inside(mid) == inside(prev) ? lo : hi) = mid;
      }
      edges.push_back((lo + hi) / 2);
    }
    prev = r;
  }
  return edges;
}

TEST(CrossoverFieller, SolvedByHand) {
  // N = 10, D = 5, vN = vD = 1, no covariance, t = 2:
  // (10 - 5r)^2 = 4 (1 + r^2)  <=>  21 r^2 - 100 r + 96 = 0
  // r = (50 -/+ sqrt(2500 - 2016)) / 21 = (50 -/+ 22) / 21 = 4/3 and 24/7.
  FiellerInterval f = fiellerInterval(10, 5, 1, 1, 0, 2);
  ASSERT_TRUE(f.bounded);
  EXPECT_NEAR(f.low, 4.0 / 3.0, 1e-14);
  EXPECT_NEAR(f.high, 24.0 / 7.0, 1e-14);
  // The denominator within t standard errors of 0 (|D| = 1 < 2 x 1): the
  // set is the complement of an interval or the whole line, never bounded.
  EXPECT_FALSE(fiellerInterval(10, 1, 1, 1, 0, 2).bounded);
  EXPECT_FALSE(fiellerInterval(0.1, 0.1, 1, 1, 0, 2).bounded);
  // Exact estimates: the point itself.
  FiellerInterval point = fiellerInterval(6, 3, 0, 0, 0, 2);
  ASSERT_TRUE(point.bounded);
  EXPECT_EQ(point.low, 2);
  EXPECT_EQ(point.high, 2);
}

TEST(CrossoverFieller, MatchesABruteForceSearch) {
  struct Case {
    double n, d, vN, vD, c, t;
  };
  // Covariance of both signs, a negative ratio, and a denominator a little
  // beyond its error (a very asymmetric interval).
  for (Case k : {Case{3e7, 12.0, 4e12, 1.5, -2e6, 2.12}, Case{-5e6, 4.0, 1e12, 2.0, 1e6, 2.12},
                 Case{9e6, 3.4, 2e13, 2.0, -4e6, 2.12}, Case{2.0, -0.5, 0.04, 0.01, 0.005, 1.96}}) {
    FiellerInterval f = fiellerInterval(k.n, k.d, k.vN, k.vD, k.c, k.t);
    ASSERT_TRUE(f.bounded) << k.n << " / " << k.d;
    double span = 50 * std::abs(k.n / k.d) + 10;
    auto edges = fiellerEdgesByScan(k.n, k.d, k.vN, k.vD, k.c, k.t, -span, span);
    ASSERT_EQ(edges.size(), 2u) << k.n << " / " << k.d;
    EXPECT_NEAR(f.low, edges[0], 1e-9 * span) << k.n << " / " << k.d;
    EXPECT_NEAR(f.high, edges[1], 1e-9 * span) << k.n << " / " << k.d;
    EXPECT_LE(f.low, k.n / k.d);
    EXPECT_GE(f.high, k.n / k.d);
  }
}

// Fits as a sweep of 10 resolutions gives them: residual SE 1e6, so
// se(b) = s / sqrt(Sxx), se(a) = s sqrt(1/n + mean^2 / Sxx), cov = -mean s^2 / Sxx.
LinearFit sweepFit(double a, double b, double s) {
  auto x = sweepPixels();
  double mean = 0, sxx = 0;
  for (double v : x) mean += v / double(x.size());
  for (double v : x) sxx += (v - mean) * (v - mean);
  LinearFit f;
  f.n = int(x.size());
  f.a = a;
  f.b = b;
  f.bSe = s / std::sqrt(sxx);
  f.aSe = s * std::sqrt(1.0 / f.n + mean * mean / sxx);
  f.covAb = -mean * s * s / sxx;
  f.minPixels = x.front();
  f.maxPixels = x.back();
  return f;
}

// Slopes that differ by 2.8 standard errors, so not parallel at 95%, and a
// crossing estimated at 3 Mpx inside the range: the delta method's
// symmetric interval lies inside the range and above 0, but Fieller's
// reaches below 0 pixels: no significant crossing. Well beyond the error
// (6 standard errors) the same pair crosses.
TEST(CrossoverCrossing, SlopesWithinThreeStandardErrorsDoNotCross) {
  const double s = 1e6, p = 3e6;
  LinearFit first = sweepFit(1e6, 40, s);
  for (double z : {2.8, 6.0}) {
    double slopeGap = z * std::sqrt(2.0) * first.bSe;
    LinearFit second = sweepFit(1e6 + p * slopeGap, 40 - slopeGap, s);
    Crossing c = crossing(first, second);
    ASSERT_TRUE(c.pixels && c.low && c.deltaLow) << z;
    EXPECT_NEAR(*c.pixels, p, 1e-6 * p);
    EXPECT_NEAR(c.slopeDifference / c.slopeDifferenceSe, z, 1e-9);
    // The bounds are the set where the t-statistic stays within t.
    double t = tQuantile(0.95, c.degreesOfFreedom);
    double vN = first.aSe * first.aSe + second.aSe * second.aSe, vD = 2 * first.bSe * first.bSe;
    auto edges = fiellerEdgesByScan(second.a - first.a, c.slopeDifference, vN, vD, -2 * first.covAb, t, -4e7, 4e7);
    ASSERT_EQ(edges.size(), 2u);
    EXPECT_NEAR(*c.low, edges[0], 1e-6 * p);
    EXPECT_NEAR(*c.high, edges[1], 1e-6 * p);
    nlohmann::json j = toJson(c, "forward", "deferred");
    if (z < 3) {
      EXPECT_GT(*c.deltaLow, 0);
      EXPECT_LT(*c.deltaHigh, c.rangeHigh);
      EXPECT_LE(*c.low, 0);
      EXPECT_EQ(c.kind, CrossingKind::NotSignificant);
      EXPECT_EQ(j["kind"], "no_significant_crossing");
      EXPECT_EQ(j["significant"], false);
      EXPECT_TRUE(j["lower_below"].is_null());
      EXPECT_TRUE(j["lower_throughout"].is_null());
      EXPECT_NE(j["why"].get<std::string>().find("0 pixels or below"), std::string::npos) << j["why"];
    } else {
      EXPECT_GT(*c.low, c.rangeLow);
      EXPECT_EQ(c.kind, CrossingKind::Crosses);
      EXPECT_EQ(j["kind"], "crosses");
    }
  }
}

// An interval beyond the measured range on both sides is no crossing either,
// even with the estimate inside the range and the interval above 0.
TEST(CrossoverCrossing, IntervalBeyondBothEndsIsNotSignificant) {
  LinearFit first = sweepFit(1e6, 40, 1e6);
  first.minPixels = 2.5e6;  // a narrow common range around the crossing
  first.maxPixels = 3.5e6;
  double slopeGap = 4.0 * std::sqrt(2.0) * first.bSe;
  LinearFit second = sweepFit(1e6 + 3e6 * slopeGap, 40 - slopeGap, 1e6);
  Crossing c = crossing(first, second);
  ASSERT_TRUE(c.low && c.high);
  EXPECT_GT(*c.low, 0);
  EXPECT_LT(*c.low, c.rangeLow);
  EXPECT_GT(*c.high, c.rangeHigh);
  EXPECT_EQ(c.kind, CrossingKind::NotSignificant);
  EXPECT_NE(c.why.find("both sides"), std::string::npos) << c.why;
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

// analysis/significance: the Mann-Whitney distribution against enumeration of
// every rank arrangement (derived here, not with the library's generating
// function), textbook critical values, Cliff's delta and the Hodges-Lehmann
// interval against brute force over all pairs, and, over thousands of
// simulated pairs of runs with fixed seeds, the false-positive rate, the power
// and the interval's coverage against their nominal levels (printed: they are
// the figures in docs/statistics.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "analysis/significance.hpp"

namespace {
using namespace tally::analysis;

// ---- independent derivations ----------------------------------------------------

// Counts of U (pairs with b above a) over every way of choosing which m of the
// m + n ranks belong to sample A.
std::vector<double> enumeratedCounts(int m, int n) {
  int total = m + n;
  std::vector<double> counts(size_t(m * n) + 1, 0.0);
  for (uint32_t mask = 0; mask < (uint32_t(1) << total); ++mask) {
    if (std::popcount(mask) != m) continue;
    int aBelow = 0, u = 0;
    for (int r = 0; r < total; ++r) {
      if (mask & (uint32_t(1) << r)) ++aBelow;
      else u += aBelow;
    }
    counts[size_t(u)] += 1;
  }
  return counts;
}

double enumeratedCdf(const std::vector<double>& counts, int u) {
  double below = 0, total = 0;
  for (size_t k = 0; k < counts.size(); ++k) {
    total += counts[k];
    if (int(k) <= u) below += counts[k];
  }
  return below / total;
}

// Brute force over all pairs: (#b > a, #b < a).
std::pair<double, double> pairCounts(const std::vector<double>& a, const std::vector<double>& b) {
  double greater = 0, less = 0;
  for (double x : a)
    for (double y : b) {
      if (y > x) greater += 1;
      if (y < x) less += 1;
    }
  return {greater, less};
}

std::vector<double> sortedLogDifferences(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> d;
  for (double x : a)
    for (double y : b) d.push_back(std::log(y) - std::log(x));
  std::sort(d.begin(), d.end());
  return d;
}

std::vector<double> lognormal(std::mt19937_64& rng, size_t n, double median, double sigma, double scale = 1) {
  std::normal_distribution<double> z(0, 1);
  std::vector<double> v(n);
  for (auto& x : v) x = scale * median * std::exp(sigma * z(rng));
  return v;
}

// Frame times with a floor: t0 plus an exponential tail of the given mean.
std::vector<double> shiftedExponential(std::mt19937_64& rng, size_t n, double t0, double mean, double scale = 1) {
  std::exponential_distribution<double> e(1 / mean);
  std::vector<double> v(n);
  for (auto& x : v) x = scale * (t0 + e(rng));
  return v;
}

// ---- the exact distribution -----------------------------------------------------

TEST(Significance, ExactDistributionMatchesEnumeration) {
  for (auto [m, n] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {3, 4}, {5, 5}, {4, 9}, {7, 6}, {10, 10}}) {
    auto counts = enumeratedCounts(m, n);
    for (int u = 0; u <= m * n; ++u)
      EXPECT_NEAR(mannWhitneyCdf(size_t(m), size_t(n), u), enumeratedCdf(counts, u), 1e-12)
          << "m=" << m << " n=" << n << " u=" << u;
  }
  // Symmetric in m and n, outside 0..mn clamped.
  EXPECT_DOUBLE_EQ(mannWhitneyCdf(4, 9, 11), mannWhitneyCdf(9, 4, 11));
  EXPECT_EQ(mannWhitneyCdf(4, 9, -1), 0);
  EXPECT_EQ(mannWhitneyCdf(4, 9, 36), 1);
  EXPECT_TRUE(std::isnan(mannWhitneyCdf(0, 9, 3)));
}

TEST(Significance, TextbookCriticalValues) {
  // m = n = 5: P(U <= 2) = 4/252 (U = 0, 1 once each, U = 2 twice), P(U <= 3) = 7/252.
  EXPECT_NEAR(mannWhitneyCdf(5, 5, 2), 4.0 / 252, 1e-15);
  EXPECT_NEAR(mannWhitneyCdf(5, 5, 3), 7.0 / 252, 1e-15);
  // The tables' two-sided 5% critical values (reject when U <= c): the largest
  // c with P(U <= c) <= 0.025.
  for (auto [n, c] : std::vector<std::pair<size_t, double>>{{5, 2}, {8, 13}, {10, 23}, {15, 64}, {20, 127}}) {
    EXPECT_LE(mannWhitneyCdf(n, n, c), 0.025) << "n=" << n;
    EXPECT_GT(mannWhitneyCdf(n, n, c + 1), 0.025) << "n=" << n;
  }
}

TEST(Significance, ExactPValuesOnDataMatchEnumeration) {
  std::mt19937_64 rng(7);
  for (auto [m, n] : std::vector<std::pair<int, int>>{{3, 4}, {6, 7}, {5, 5}, {8, 9}}) {
    auto counts = enumeratedCounts(m, n);
    for (int trial = 0; trial < 20; ++trial) {
      auto a = lognormal(rng, size_t(m), 16, 0.1);
      auto b = lognormal(rng, size_t(n), 16, 0.1, 1 + 0.02 * trial);
      auto t = mannWhitney(a, b);
      ASSERT_TRUE(t.ok()) << t.error();
      ASSERT_TRUE(t->exact);
      auto [greater, less] = pairCounts(a, b);
      EXPECT_EQ(t->u, greater);
      int u = int(greater);
      double lowerTail = enumeratedCdf(counts, u), upperTail = 1 - enumeratedCdf(counts, u - 1);
      EXPECT_NEAR(t->pValue, std::min(1.0, 2 * std::min(lowerTail, upperTail)), 1e-12);
    }
  }
}

TEST(Significance, NormalApproximationAgreesWithExactAtModerateN) {
  // m = n = 30 without ties: the continuity-corrected normal p-value lies
  // within 0.005 of the exact one over the whole range of p.
  std::mt19937_64 rng(11);
  double worst = 0;
  int spanned = 0;
  for (int trial = 0; trial < 200; ++trial) {
    auto a = lognormal(rng, 30, 16, 0.1);
    auto b = lognormal(rng, 30, 16, 0.1, 1 + 0.0005 * trial);
    auto exact = mannWhitney(a, b, PValueMethod::Exact);
    auto normal = mannWhitney(a, b, PValueMethod::Normal);
    ASSERT_TRUE(exact.ok() && normal.ok());
    EXPECT_EQ(exact->u, normal->u);
    EXPECT_FALSE(normal->exact);
    worst = std::max(worst, std::abs(exact->pValue - normal->pValue));
    if (exact->pValue > 0.01 && exact->pValue < 0.5) ++spanned;
  }
  std::printf("normal vs exact p-value, m = n = 30, 200 samples: max |difference| %.5f\n", worst);
  EXPECT_LT(worst, 0.005);
  EXPECT_GT(spanned, 20);  // the comparison covered the p-values that matter
  // Exact is for samples without ties: asked for with ties, an error; chosen
  // automatically, the normal approximation with the tie correction.
  std::vector<double> a = {10, 11, 12, 12, 13}, b = {12, 14, 15, 16, 16};
  auto forced = mannWhitney(a, b, PValueMethod::Exact);
  ASSERT_FALSE(forced.ok());
  EXPECT_NE(forced.error().find("ties"), std::string::npos);
  auto automatic = mannWhitney(a, b);
  ASSERT_TRUE(automatic.ok());
  EXPECT_FALSE(automatic->exact);
  EXPECT_TRUE(automatic->ties);
  // b = 12 lies above 10 and 11, ties the two 12s and lies below 13; the
  // other four lie above all five: 22 pairs above, 1 below, 2 tied, U = 23.
  auto [greater, less] = pairCounts(a, b);
  EXPECT_EQ(greater, 22);
  EXPECT_EQ(less, 1);
  EXPECT_EQ(automatic->u, 23);
  // Tie-corrected variance: groups {12 x3}, {16 x2}: sum t^3 - t = 24 + 6 = 30;
  // var = 25/12 (11 - 30/90); z = (U - 12.5 - 0.5) / sd.
  double sd = std::sqrt(25.0 / 12 * (11 - 30.0 / 90));
  EXPECT_NEAR(automatic->z, (automatic->u - 12.5 - 0.5) / sd, 1e-12);
  EXPECT_NEAR(automatic->pValue, std::erfc(automatic->z / std::sqrt(2.0)), 1e-12);
}

// ---- effect size and interval ---------------------------------------------------

TEST(Significance, CliffsDeltaMatchesPairCount) {
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    size_t m = 5 + size_t(trial % 17), n = 3 + size_t(trial % 23);
    // Rounded to whole milliseconds, so there are many ties.
    auto a = lognormal(rng, m, 16, 0.15), b = lognormal(rng, n, 16, 0.15, 1 + 0.01 * (trial % 7));
    for (auto& x : a) x = std::round(x);
    for (auto& x : b) x = std::round(x);
    auto [greater, less] = pairCounts(a, b);
    double expected = (greater - less) / double(m * n);
    auto d = cliffsDelta(a, b);
    ASSERT_TRUE(d.ok());
    EXPECT_DOUBLE_EQ(d->delta, expected);
    EXPECT_EQ(d->magnitude, cliffMagnitude(expected));
    auto c = compareTimes(a, b);
    ASSERT_TRUE(c.ok());
    EXPECT_DOUBLE_EQ(c->effect.delta, expected);
  }
  EXPECT_EQ(cliffMagnitude(0.1469), EffectMagnitude::Negligible);
  EXPECT_EQ(cliffMagnitude(-0.147), EffectMagnitude::Small);
  EXPECT_EQ(cliffMagnitude(0.3299), EffectMagnitude::Small);
  EXPECT_EQ(cliffMagnitude(0.33), EffectMagnitude::Medium);
  EXPECT_EQ(cliffMagnitude(-0.474), EffectMagnitude::Large);
  EXPECT_EQ(cliffMagnitude(1), EffectMagnitude::Large);
  EXPECT_STREQ(toString(EffectMagnitude::Medium), "medium");
  // Fully separated: delta is 1 when B takes longer, -1 when shorter.
  EXPECT_EQ(cliffsDelta({1, 2, 3}, {4, 5})->delta, 1);
  EXPECT_EQ(cliffsDelta({4, 5}, {1, 2, 3})->delta, -1);
}

TEST(Significance, HodgesLehmannIntervalMatchesBruteForce) {
  std::mt19937_64 rng(5);
  // Exact, m = n = 10: the 5% critical value is 23 (enumerated here), so the
  // interval runs from the 24th to the 77th of the 100 sorted differences.
  auto counts = enumeratedCounts(10, 10);
  int k = 0;
  while (enumeratedCdf(counts, k) <= 0.025) ++k;  // k - 1 = 23 is the last with P(U <= k - 1) <= 0.025
  ASSERT_EQ(k, 24);
  for (int trial = 0; trial < 10; ++trial) {
    auto a = lognormal(rng, 10, 16, 0.1), b = lognormal(rng, 10, 16, 0.1, 1.05);
    auto d = sortedLogDifferences(a, b);
    auto r = ratioInterval(a, b);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->method, "hodges-lehmann-exact");
    EXPECT_EQ(r->rank, 24u);
    EXPECT_TRUE(r->bounded);
    EXPECT_DOUBLE_EQ(r->estimate, std::exp((d[49] + d[50]) / 2));
    EXPECT_DOUBLE_EQ(r->lower, std::exp(d[23]));
    EXPECT_DOUBLE_EQ(r->upper, std::exp(d[76]));
    EXPECT_NEAR(r->achieved, 1 - 2 * enumeratedCdf(counts, 23), 1e-12);
    EXPECT_GE(r->achieved, 0.95);
  }
  // Normal approximation, m = 60, n = 55 (no ties): k = floor(mn/2 + 1/2 -
  // z(0.975) sqrt(mn (m + n + 1) / 12)).
  for (int trial = 0; trial < 5; ++trial) {
    auto a = lognormal(rng, 60, 16, 0.1), b = lognormal(rng, 55, 16, 0.1, 0.97);
    auto d = sortedLogDifferences(a, b);
    auto r = ratioInterval(a, b);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->method, "hodges-lehmann-normal");
    double mn = 60.0 * 55;
    auto kn = size_t(std::floor(mn / 2 + 0.5 - 1.959963984540054 * std::sqrt(mn * 116 / 12)));
    EXPECT_EQ(r->rank, kn);
    EXPECT_DOUBLE_EQ(r->lower, std::exp(d[kn - 1]));
    EXPECT_DOUBLE_EQ(r->upper, std::exp(d[size_t(mn) - kn]));
    EXPECT_DOUBLE_EQ(r->estimate, std::exp((d[1649] + d[1650]) / 2));  // mn = 3300
  }
  // An odd number of pairs: the middle difference itself.
  std::vector<double> a = {10, 12, 15}, b = {11, 13, 20};
  auto d = sortedLogDifferences(a, b);
  EXPECT_DOUBLE_EQ(ratioInterval(a, b)->estimate, std::exp(d[4]));
}

// ---- verdicts --------------------------------------------------------------------

TEST(Significance, VerdictRule) {
  // Too small for 95%: 3 against 3 fully separated has p = 2/20 and no
  // bounded interval, so the verdict is "same".
  auto small = compareTimes({10, 11, 12}, {20, 21, 22});
  ASSERT_TRUE(small.ok());
  EXPECT_NEAR(small->test.pValue, 0.1, 1e-12);
  EXPECT_FALSE(small->interval.bounded);
  EXPECT_EQ(small->interval.rank, 0u);
  EXPECT_TRUE(std::isinf(small->interval.upper));
  EXPECT_EQ(small->verdict, Verdict::Same);
  EXPECT_TRUE(toJson(*small)["interval"]["upper"].is_null());
  // 4 against 4 fully separated: p = 2/70, the interval is [D(1), D(16)].
  auto four = compareTimes({10, 11, 12, 13}, {20, 21, 22, 23});
  ASSERT_TRUE(four.ok());
  EXPECT_NEAR(four->test.pValue, 2.0 / 70, 1e-12);
  EXPECT_EQ(four->interval.rank, 1u);
  EXPECT_DOUBLE_EQ(four->interval.lower, 20.0 / 13);
  EXPECT_DOUBLE_EQ(four->interval.upper, 23.0 / 10);
  EXPECT_EQ(four->verdict, Verdict::Slower);
  EXPECT_DOUBLE_EQ(four->ratio, 21.5 / 11.5);
  EXPECT_EQ(four->effect.magnitude, EffectMagnitude::Large);
  auto reversed = compareTimes({20, 21, 22, 23}, {10, 11, 12, 13});
  EXPECT_EQ(reversed->verdict, Verdict::Faster);
  EXPECT_STREQ(toString(reversed->verdict), "faster");

  // A real 2% difference over 200 frames each: significant; with a practical
  // threshold of 5% it is "same", with 1% "slower".
  std::mt19937_64 rng(17);
  auto a = lognormal(rng, 200, 16, 0.03), b = lognormal(rng, 200, 16, 0.03, 1.02);
  auto plain = compareTimes(a, b);
  ASSERT_TRUE(plain.ok());
  EXPECT_LT(plain->test.pValue, 1e-4);
  EXPECT_EQ(plain->verdict, Verdict::Slower);
  EXPECT_EQ(compareTimes(a, b, {.practicalThreshold = 0.01})->verdict, Verdict::Slower);
  auto practical = compareTimes(a, b, {.practicalThreshold = 0.05});
  EXPECT_EQ(practical->verdict, Verdict::Same);
  EXPECT_NE(practical->reason.find("practical threshold"), std::string::npos) << practical->reason;
  auto json = toJson(*plain);
  EXPECT_EQ(json["verdict"], "slower");
  EXPECT_EQ(json["mann_whitney"]["method"], "normal");
  EXPECT_EQ(json["interval"]["method"], "hodges-lehmann-normal");

  // Identical samples: ratio 1, p = 1, a zero-width interval at 1.
  std::vector<double> flat(10, 16.0);
  auto same = compareTimes(flat, flat);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->ratio, 1);
  EXPECT_EQ(same->test.pValue, 1);
  EXPECT_EQ(same->interval.lower, 1);
  EXPECT_EQ(same->interval.upper, 1);
  EXPECT_EQ(same->verdict, Verdict::Same);
  // ... and with across-capture noise, the across-capture interval alone.
  auto noisy = compareTimes(flat, flat, {.acrossCaptureLogSd = 0.05});
  EXPECT_TRUE(std::isinf(noisy->interval.widening));
  EXPECT_NEAR(std::log(noisy->interval.upper), 1.959963984540054 * std::sqrt(2.0) * 0.05, 1e-9);
  EXPECT_TRUE(toJson(*noisy)["interval"]["widening"].is_null());
}

TEST(Significance, AcrossCaptureWidening) {
  auto sd = acrossCaptureLogSd({16, 16 * std::exp(0.1), 16 * std::exp(-0.1)});
  ASSERT_TRUE(sd.ok());
  EXPECT_NEAR(*sd, 0.1, 1e-12);  // logs -0.1, 0, 0.1 around 0: sqrt(0.02 / 2)
  EXPECT_EQ(*acrossCaptureLogSd({16}), 0);
  EXPECT_FALSE(acrossCaptureLogSd({16, 0}).ok());
  // Student's t with 4 degrees of freedom: t(0.975) = 2.776445.
  EXPECT_NEAR(acrossCaptureHalfWidth(0.1, 5, 0.95), 2.7764451051977987 * std::sqrt(2.0) * 0.1, 1e-9);
  EXPECT_NEAR(acrossCaptureHalfWidth(0.1, 0, 0.95), 1.959963984540054 * std::sqrt(2.0) * 0.1, 1e-9);
  EXPECT_EQ(acrossCaptureHalfWidth(0, 5, 0.95), 0);

  std::mt19937_64 rng(23);
  auto a = lognormal(rng, 100, 16, 0.05), b = lognormal(rng, 100, 16, 0.05, 1.03);
  auto plain = compareTimes(a, b);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->verdict, Verdict::Slower);
  EXPECT_EQ(plain->interval.widening, 1);
  // Across-capture noise far smaller than the frames' own interval: its
  // variance adds next to nothing.
  auto quiet = compareTimes(a, b, {.acrossCaptureLogSd = 0.001, .acrossCaptureRuns = 5});
  EXPECT_GT(quiet->interval.widening, 1);
  EXPECT_LT(quiet->interval.widening, 1.05);
  EXPECT_LT(quiet->interval.lower, plain->interval.lower);
  // Larger: each log half-width h becomes sqrt(h^2 + H^2), H the
  // across-capture half-width, about the same centre, and a 3% difference is
  // no longer shown to be real.
  auto loud = compareTimes(a, b, {.acrossCaptureLogSd = 0.03, .acrossCaptureRuns = 5});
  ASSERT_TRUE(loud.ok());
  EXPECT_GT(loud->interval.widening, 1);
  const double across = acrossCaptureHalfWidth(0.03, 5, 0.95), centre = std::log(plain->interval.estimate);
  const double below = centre - std::log(plain->interval.lower), above = std::log(plain->interval.upper) - centre;
  EXPECT_NEAR(centre - std::log(loud->interval.lower), std::sqrt(below * below + across * across), 1e-12);
  EXPECT_NEAR(std::log(loud->interval.upper) - centre, std::sqrt(above * above + across * across), 1e-12);
  EXPECT_NEAR(loud->interval.widening,
              (std::sqrt(below * below + across * across) + std::sqrt(above * above + across * across)) / (below + above),
              1e-12);
  EXPECT_NEAR(std::log(loud->interval.estimate), std::log(plain->interval.estimate), 1e-15);
  EXPECT_EQ(loud->test.pValue, plain->test.pValue);  // the test is the frames' own
  EXPECT_EQ(loud->verdict, Verdict::Same);
  EXPECT_NE(loud->reason.find("across-capture"), std::string::npos) << loud->reason;
}

TEST(Significance, Errors) {
  std::vector<double> ok = {10, 11, 12};
  auto expectError = [](const tally::Result<TimeComparison>& r, const std::string& text) {
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().find(text), std::string::npos) << r.error();
  };
  expectError(compareTimes({}, ok), "sample A is empty");
  expectError(compareTimes(ok, {}), "sample B is empty");
  expectError(compareTimes({10}, ok), "sample A has 1 time");
  expectError(compareTimes(ok, {12}), "sample B has 1 time");
  expectError(compareTimes({10, 0, 12}, ok), "sample A: time 1 is not positive");
  expectError(compareTimes(ok, {10, -3}), "sample B: time 1 is not positive");
  expectError(compareTimes({10, std::nan("")}, ok), "sample A: time 1 is not finite");
  expectError(compareTimes(ok, {std::numeric_limits<double>::infinity(), 3}), "sample B: time 0 is not finite");
  expectError(compareTimes(ok, ok, {.confidence = 1}), "confidence");
  expectError(compareTimes(ok, ok, {.confidence = 0}), "confidence");
  expectError(compareTimes(ok, ok, {.practicalThreshold = -0.1}), "practical threshold");
  expectError(compareTimes(ok, ok, {.acrossCaptureLogSd = std::nan("")}), "across-capture");
  expectError(compareTimes({10, 10, 11}, ok, {.pValueMethod = PValueMethod::Exact}), "ties");
  EXPECT_FALSE(mannWhitney({}, ok).ok());
  EXPECT_FALSE(cliffsDelta(ok, {1}).ok());
  EXPECT_FALSE(ratioInterval(ok, ok, 1.5).ok());
  EXPECT_FALSE(mannWhitney(std::vector<double>(201, 1.0), ok, PValueMethod::Exact).ok());
}

TEST(Significance, CountsCompareExactly) {
  auto same = compareCounts(921600, 921600);
  EXPECT_EQ(same.verdict, CountVerdict::Same);
  EXPECT_EQ(same.delta, 0);
  auto changed = compareCounts(921600, 921601);
  EXPECT_EQ(changed.verdict, CountVerdict::Changed);
  EXPECT_EQ(changed.delta, 1);
  EXPECT_EQ(compareCounts(2304.5, 2304).delta, -0.5);
  EXPECT_EQ(toJson(changed)["verdict"], "changed");
  EXPECT_STREQ(toString(CountVerdict::Same), "same");
}

// ---- rates over many simulated runs ------------------------------------------------

constexpr int kReplications = 2000;
constexpr double kAlpha = 0.05;

// Three binomial standard deviations of a rate p over n trials.
double tolerance(double p, double n) { return 3 * std::sqrt(p * (1 - p) / n); }

using Generator = std::function<std::vector<double>(std::mt19937_64&, size_t, double)>;

struct Rates {
  double falsePositive = 0, power = 0, wrongWay = 0, coverage = 0, achieved = 0;
  int exactCalls = 0, calls = 0;
};

// kReplications pairs of runs with no difference, and kReplications with B
// 10% slower (even) or 10% faster (odd): verdicts and whether the interval
// holds the true ratio (1, 1.1 or 1/1.1).
Rates simulate(const Generator& times, size_t nA, size_t nB, uint64_t seed, double shift = 1.10) {
  std::mt19937_64 rng(seed);
  Rates r;
  int falsePositives = 0, detected = 0, wrongWay = 0, covered = 0;
  double achieved = 0;
  auto record = [&](const TimeComparison& c, double truth) {
    covered += c.interval.lower <= truth && truth <= c.interval.upper;
    achieved += c.interval.achieved;
    r.exactCalls += c.test.exact;
    ++r.calls;
  };
  for (int i = 0; i < kReplications; ++i) {
    auto a = times(rng, nA, 1), b = times(rng, nB, 1);
    auto c = compareTimes(a, b);
    EXPECT_TRUE(c.ok());
    falsePositives += c->verdict != Verdict::Same;
    record(*c, 1);

    double truth = i % 2 ? 1 / shift : shift;
    a = times(rng, nA, 1), b = times(rng, nB, truth);
    c = compareTimes(a, b);
    EXPECT_TRUE(c.ok());
    Verdict expected = truth > 1 ? Verdict::Slower : Verdict::Faster;
    detected += c->verdict == expected;
    wrongWay += c->verdict != expected && c->verdict != Verdict::Same;
    record(*c, truth);
  }
  r.falsePositive = falsePositives / double(kReplications);
  r.power = detected / double(kReplications);
  r.wrongWay = wrongWay / double(kReplications);
  r.coverage = covered / double(2 * kReplications);
  r.achieved = achieved / double(2 * kReplications);
  return r;
}

void report(const char* name, size_t nA, size_t nB, const Rates& r) {
  std::printf("%-34s nA=%-3zu nB=%-3zu exact %4.0f%%  false positives %.4f  power(10%%) %.4f  "
              "coverage %.4f (achieved level %.4f)\n",
              name, nA, nB, 100.0 * r.exactCalls / r.calls, r.falsePositive, r.power, r.coverage, r.achieved);
}

// The stated levels: the false-positive rate within three binomial standard
// deviations of alpha (at most: the exact test's size is <= alpha), coverage
// within three of the nominal 95% (the exact interval's achieved level is a
// little above it; with ties, maxCoverage), and the power at least minPower.
void expectRates(const Rates& r, double minPower, double maxCoverage = 0) {
  EXPECT_LE(r.falsePositive, kAlpha + tolerance(kAlpha, kReplications));
  EXPECT_GE(r.falsePositive, kAlpha - tolerance(kAlpha, kReplications));
  EXPECT_GE(r.coverage, 0.95 - tolerance(0.95, 2 * kReplications));
  EXPECT_LE(r.coverage, maxCoverage > 0 ? maxCoverage : r.achieved + tolerance(0.95, 2 * kReplications));
  EXPECT_GE(r.power, minPower);
  EXPECT_EQ(r.wrongWay, 0);
}

// Frame times: lognormal, median 16 ms, 8% spread (sigma of log time).
std::vector<double> lognormalFrames(std::mt19937_64& rng, size_t n, double scale) {
  return lognormal(rng, n, 16, 0.08, scale);
}
// Frame times with a floor: 14 ms plus an exponential tail of mean 2 ms.
std::vector<double> floorAndTailFrames(std::mt19937_64& rng, size_t n, double scale) {
  return shiftedExponential(rng, n, 14, 2, scale);
}

TEST(SignificanceRates, LognormalFrameTimes) {
  for (auto [n, minPower] : std::vector<std::pair<size_t, double>>{{20, 0.80}, {40, 0.97}, {60, 0.99}}) {
    auto r = simulate(lognormalFrames, n, n, 1000 + n);
    report("lognormal (16 ms, sigma 0.08)", n, n, r);
    expectRates(r, minPower);
  }
  auto r = simulate(lognormalFrames, 20, 60, 1999);
  report("lognormal (16 ms, sigma 0.08)", 20, 60, r);
  expectRates(r, 0.90);
}

TEST(SignificanceRates, ShiftedExponentialFrameTimes) {
  for (auto [n, minPower] : std::vector<std::pair<size_t, double>>{{20, 0.80}, {40, 0.97}, {60, 0.99}}) {
    auto r = simulate(floorAndTailFrames, n, n, 2000 + n);
    report("14 ms + exponential (mean 2 ms)", n, n, r);
    expectRates(r, minPower);
  }
}

TEST(SignificanceRates, TimesWithTies) {
  // Timestamps of 0.1 ms resolution: many tied times, so the normal
  // approximation with the tie correction. The shift is applied before the
  // rounding, so the interval's truth is only near 1.1. The interval is
  // closed and ties put pairwise differences exactly on the truth (0 in log
  // space) for the runs without a difference: its coverage is above 95%.
  Generator quantised = [](std::mt19937_64& rng, size_t n, double scale) {
    auto v = lognormalFrames(rng, n, scale);
    for (auto& x : v) x = std::round(x * 10) / 10;
    return v;
  };
  auto r = simulate(quantised, 40, 40, 3040);
  report("lognormal, 0.1 ms resolution", 40, 40, r);
  EXPECT_EQ(r.exactCalls, 0);
  expectRates(r, 0.97, 0.975);
}

TEST(SignificanceRates, AcrossCaptureNoise) {
  // Each capture's frames are scaled by its own exp(N(0, 0.03)): captures of
  // one configuration differ by about 3%, so two captures by about 4.2%
  // (95%: +-8%), far more than the frames' own interval (+-3.6% for 40 frames
  // of 8% spread) allows. Run A and run B are two captures with no real
  // difference; the across-capture spread comes from 5 earlier captures.
  constexpr double kTau = 0.03;
  constexpr size_t kFrames = 40, kRepeats = 5;
  std::mt19937_64 rng(4242);
  std::normal_distribution<double> offset(0, kTau);
  auto capture = [&](double scale) { return lognormalFrames(rng, kFrames, scale * std::exp(offset(rng))); };
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
  };
  int plainFalse = 0, widenedFalse = 0, widenedCovered = 0, widenedDetected = 0;
  for (int i = 0; i < kReplications; ++i) {
    std::vector<double> medians;
    for (size_t k = 0; k < kRepeats; ++k) medians.push_back(median(capture(1)));
    double sd = *acrossCaptureLogSd(medians);
    auto a = capture(1), b = capture(1);
    CompareOptions options{.acrossCaptureLogSd = sd, .acrossCaptureRuns = kRepeats};
    auto plain = compareTimes(a, b), widened = compareTimes(a, b, options);
    ASSERT_TRUE(plain.ok() && widened.ok());
    plainFalse += plain->verdict != Verdict::Same;
    widenedFalse += widened->verdict != Verdict::Same;
    widenedCovered += widened->interval.lower <= 1 && 1 <= widened->interval.upper;
    // A 15% difference still shows through the across-capture noise.
    auto slower = compareTimes(capture(1), capture(1.15), options);
    widenedDetected += slower->verdict == Verdict::Slower;
  }
  double plainRate = plainFalse / double(kReplications), widenedRate = widenedFalse / double(kReplications);
  double coverage = widenedCovered / double(kReplications), power = widenedDetected / double(kReplications);
  std::printf("across-capture sd 0.03, %zu frames, %zu repeats: false positives %.4f without widening, "
              "%.4f widened (interval holds 1: %.4f); power(15%%) widened %.4f\n",
              kFrames, kRepeats, plainRate, widenedRate, coverage, power);
  EXPECT_GT(plainRate, 0.3);  // why the widening exists
  EXPECT_LE(widenedRate, kAlpha + tolerance(kAlpha, kReplications));
  EXPECT_GE(coverage, 0.95 - tolerance(0.95, kReplications));
  EXPECT_GE(power, 0.5);
}

}  // namespace

// Ten cameras whose frame times differ by up to 3x (4 to 13 ms, lognormal,
// sigma of log 0.05), 8 frames each, B slower by a factor common to every
// camera. Pooled over cameras, the camera-to-camera spread hides a 2%
// difference; aligned per camera (alignStrata), the test keeps its level,
// the interval its coverage, and the difference shows.
TEST(SignificanceRates, CamerasAsStrata) {
  constexpr size_t kCamerasPerRun = 10, kFramesPerCamera = 8;
  constexpr double kShift = 1.02;
  std::mt19937_64 rng(5150);
  auto run = [&](double scale) {
    std::vector<std::vector<double>> cams;
    for (size_t c = 0; c < kCamerasPerRun; ++c) cams.push_back(lognormal(rng, kFramesPerCamera, 4.0 + c, 0.05, scale));
    return cams;
  };
  auto pooled = [](const std::vector<std::vector<double>>& cams) {
    std::vector<double> all;
    for (const auto& c : cams) all.insert(all.end(), c.begin(), c.end());
    return all;
  };
  auto aligned = [](const std::vector<std::vector<double>>& a, const std::vector<std::vector<double>>& b) {
    std::vector<Stratum> strata;
    for (size_t c = 0; c < a.size(); ++c) strata.push_back({a[c], b[c]});
    auto out = alignStrata(strata);
    EXPECT_TRUE(out.ok());
    return *out;
  };
  int pooledFalse = 0, alignedFalse = 0, pooledDetected = 0, alignedDetected = 0, alignedCovered = 0, wrongWay = 0;
  for (int i = 0; i < kReplications; ++i) {
    auto a = run(1), b = run(1);
    auto same = aligned(a, b);
    auto p0 = compareTimes(pooled(a), pooled(b)), a0 = compareTimes(same.a, same.b);
    ASSERT_TRUE(p0.ok() && a0.ok());
    pooledFalse += p0->verdict != Verdict::Same;
    alignedFalse += a0->verdict != Verdict::Same;
    alignedCovered += a0->interval.lower <= 1 && 1 <= a0->interval.upper;

    double truth = i % 2 ? 1 / kShift : kShift;
    b = run(truth);
    auto shifted = aligned(a, b);
    auto p1 = compareTimes(pooled(a), pooled(b)), a1 = compareTimes(shifted.a, shifted.b);
    ASSERT_TRUE(p1.ok() && a1.ok());
    Verdict expected = truth > 1 ? Verdict::Slower : Verdict::Faster;
    pooledDetected += p1->verdict == expected;
    alignedDetected += a1->verdict == expected;
    wrongWay += a1->verdict != expected && a1->verdict != Verdict::Same;
    alignedCovered += a1->interval.lower <= truth && truth <= a1->interval.upper;
  }
  double n = kReplications;
  std::printf("10 cameras (4-13 ms) x 8 frames, 2%% shift: pooled false positives %.4f power %.4f; aligned false "
              "positives %.4f power %.4f coverage %.4f\n",
              pooledFalse / n, pooledDetected / n, alignedFalse / n, alignedDetected / n, alignedCovered / (2 * n));
  EXPECT_LT(pooledDetected / n, 0.3);  // why cameras are strata
  EXPECT_LE(alignedFalse / n, kAlpha + tolerance(kAlpha, n));
  EXPECT_GE(alignedCovered / (2 * n), 0.95 - tolerance(0.95, 2 * n));
  EXPECT_GE(alignedDetected / n, 0.6);  // a t-test on log times with known sigma would have about 0.70
  EXPECT_EQ(wrongWay, 0);
}

TEST(Significance, AlignStrataScalesEachStratumToTheGrandMedian) {
  // Stratum 0: A {1, 3}, B {2}: median 2. Stratum 1: A {10}, B {20, 30}: median 20.
  // All together {1, 2, 3, 10, 20, 30}: median 6.5.
  auto out = alignStrata({{{1, 3}, {2}}, {{10}, {20, 30}}});
  ASSERT_TRUE(out.ok()) << out.error();
  std::vector<double> a = {1 * 6.5 / 2, 3 * 6.5 / 2, 10 * 6.5 / 20}, b = {2 * 6.5 / 2, 20 * 6.5 / 20, 30 * 6.5 / 20};
  EXPECT_EQ(out->a, a);
  EXPECT_EQ(out->b, b);
  EXPECT_EQ(alignStrata({}).error(), "no strata to align");
  EXPECT_EQ(alignStrata({{{1}, {}}}).error(), "stratum 0 has no time in sample B");
  EXPECT_NE(alignStrata({{{1}, {0}}}).error().find("stratum 0, sample B: time 0 is not positive (0 ms)"),
            std::string::npos);
}

namespace {

bool hasTie(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return std::adjacent_find(v.begin(), v.end()) != v.end();
}

}  // namespace

// Times of 0.01 ms resolution in two cameras, twelve different values. Scaled
// by grand / median the way a product rounds, 8.75 x (11.84 / 10.15) and
// 10.75 x (11.84 / 12.47) are one double, though 8.75 / 10.15 and
// 10.75 / 12.47 differ as the doubles they are: a tie the raw frames do not
// have, which would switch the test to the normal approximation. Aligned in
// exact order, they stay apart, and the exact test is used.
TEST(Significance, AlignmentCreatesNoTie) {
  std::vector<Stratum> strata{{{6.45, 5.91, 11.55}, {8.75, 13.27, 13.82}}, {{12.81, 12.13, 10.75}, {13.0, 9.12, 12.88}}};
  std::vector<double> raw;
  for (const auto& s : strata) {
    raw.insert(raw.end(), s.a.begin(), s.a.end());
    raw.insert(raw.end(), s.b.begin(), s.b.end());
  }
  ASSERT_FALSE(hasTie(raw));
  // The rounded products alone: the tie this test is about.
  const double grand = (11.55 + 12.13) / 2, median0 = (8.75 + 11.55) / 2, median1 = (12.13 + 12.81) / 2;
  ASSERT_EQ(8.75 * (grand / median0), 10.75 * (grand / median1));
  ASSERT_NE(8.75 * median1, 10.75 * median0);  // the exact values differ

  auto out = alignStrata(strata);
  ASSERT_TRUE(out.ok()) << out.error();
  std::vector<double> pooled = out->a;
  pooled.insert(pooled.end(), out->b.begin(), out->b.end());
  EXPECT_FALSE(hasTie(pooled));
  // Still the aligned values, to a few units in the last place.
  EXPECT_NEAR(out->b[0], 8.75 * grand / median0, 1e-14);
  EXPECT_NEAR(out->a[5], 10.75 * grand / median1, 1e-14);
  // Their order is that of time / median.
  EXPECT_EQ(out->b[0] < out->a[5], 8.75 / median0 < 10.75 / median1);
  auto test = mannWhitney(out->a, out->b);
  ASSERT_TRUE(test.ok());
  EXPECT_TRUE(test->exact);
  EXPECT_FALSE(test->ties);
}

// Ties the exact values have are kept: a camera whose times are 3 times
// another's aligns onto it value for value, however the factors round.
TEST(Significance, AlignmentKeepsExactTies) {
  // Multiples of 1/64: 3 x v is exact, so the exact ratios are equal.
  std::vector<double> a{3.125, 5.3125, 7.875}, b{9.6875, 11.3125, 13.140625}, a3, b3;
  for (double v : a) a3.push_back(3 * v);
  for (double v : b) b3.push_back(3 * v);
  auto out = alignStrata({{a, b}, {a3, b3}});
  ASSERT_TRUE(out.ok()) << out.error();
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(out->a[i], out->a[3 + i]) << i;
    EXPECT_EQ(out->b[i], out->b[3 + i]) << i;
  }
  auto test = mannWhitney(out->a, out->b);
  ASSERT_TRUE(test.ok());
  EXPECT_TRUE(test->ties);
}

// Crossover models: how a renderer's bytes per frame or frame time grows with
// the pixel count, and at what pixel count two renderers cross. Each series
// is fitted as a fixed cost plus a per-pixel cost, y = a + b * pixels, by
// ordinary least squares; a and b get standard errors and t intervals, and
// two fits cross at pixels* = (a2 - a1) / (b1 - b2), whose interval is
// Fieller's (the delta method's is given beside it). Pure: plain numbers in,
// numbers out. docs/measurement.md ("Crossover") states the model, its
// assumptions and the decisions below.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"

namespace tally::analysis {

// Two-sided confidence level of every interval here.
inline constexpr double kCrossoverConfidence = 0.95;
// A fit whose R² is below this is flagged "poor": the linear model does not
// describe the series, and its crossing should not be trusted.
inline constexpr double kPoorFitR2 = 0.9;

struct FitPoint {
  double pixels = 0;
  double value = 0;
  double residual = 0;  // value - (a + b * pixels)
};

struct LinearFit {
  int n = 0;                       // points
  double a = 0, b = 0;             // fixed cost, cost per pixel
  double aSe = 0, bSe = 0;         // standard errors
  double covAb = 0;                // covariance of the two estimates
  double aLow = 0, aHigh = 0;      // t interval for a (n - 2 degrees of freedom)
  double bLow = 0, bHigh = 0;      // and for b
  double residualSe = 0;           // sqrt(SSE / (n - 2))
  double r2 = 0;                   // 1 - SSE / SST (1 when every value is equal and fitted exactly)
  bool poor = false;               // r2 < kPoorFitR2
  double confidence = kCrossoverConfidence;
  double minPixels = 0, maxPixels = 0;
  std::vector<FitPoint> points;    // in the order given
};

// Fits y = a + b * pixels. Errors: fewer than 3 points, sizes that differ,
// non-finite values, every pixel count the same (the slope is undetermined).
Result<LinearFit> fitLinear(const std::vector<double>& pixels, const std::vector<double>& values,
                            double confidence = kCrossoverConfidence);

enum class CrossingKind {
  Crosses,        // the lines cross inside the range both fits measured, and the interval says so
  OutsideRange,   // the whole interval lies outside that range: one is lower throughout it
  Parallel,       // the slopes do not differ beyond their error: no crossing can be located
  // The slopes differ, but the crossing's interval reaches 0 pixels or below,
  // or spans the measured range and beyond on both sides, or overlaps the
  // range while the estimate lies outside it: where, or whether, the lines
  // cross in the measured range is not established.
  NotSignificant,
};
// "crosses", "outside_range", "parallel", "no_significant_crossing"
const char* crossingKindName(CrossingKind kind);

// A 16:9 resolution with (about) a given pixel count: height = round(sqrt(p * 9 / 16)),
// width = round(height * 16 / 9). Empty for a non-positive or non-finite count.
struct Resolution169 {
  int width = 0, height = 0;
};
std::optional<Resolution169> resolution169(double pixels);

// Fieller's confidence set for a ratio N / D of two normal estimates with
// variances vN, vD and covariance cND: every r with (N - r D)^2 <= t^2 (vN -
// 2 r cND + r^2 vD). It is an interval only when D differs from 0 beyond its
// error (D^2 > t^2 vD); otherwise it is the whole line or the complement of an
// interval, both unbounded (bounded false).
struct FiellerInterval {
  bool bounded = false;
  double low = 0, high = 0;  // when bounded
};
FiellerInterval fiellerInterval(double numerator, double denominator, double varNumerator, double varDenominator,
                                double covariance, double t);

struct Crossing {
  CrossingKind kind = CrossingKind::Parallel;
  // pixels* = (a2 - a1) / (b1 - b2); absent when parallel. pixelsSe is the
  // delta method's standard error; [low, high] is Fieller's interval and
  // decides the kind; [deltaLow, deltaHigh] the symmetric delta-method one.
  std::optional<double> pixels, pixelsSe, low, high, deltaLow, deltaHigh;
  std::string why;  // for NotSignificant: what the interval reaches (empty otherwise)
  // The range both fits measured: [max of minima, min of maxima].
  double rangeLow = 0, rangeHigh = 0;
  // Difference of slopes b1 - b2 and its standard error.
  double slopeDifference = 0, slopeDifferenceSe = 0;
  // Which fit (0: the first, 1: the second) is lower: below the crossing and
  // above it when it crosses, throughout the range otherwise (for parallel
  // lines, the one with the lower fitted value at the range's middle).
  int lowerBelow = 0, lowerAbove = 0;
  double confidence = kCrossoverConfidence;
  int degreesOfFreedom = 0;  // n1 + n2 - 4
};

// Where `first` and `second` cross. Parallel when |b1 - b2| <= t * se(b1 - b2)
// (the fits are independent: their variances add), which is exactly when
// Fieller's set is unbounded. Otherwise the crossing's interval is Fieller's
// over (a2 - a1, b1 - b2), and its standard error the delta method's, with
// the t quantile for n1 + n2 - 4 degrees of freedom. The kind follows
// Fieller's interval, not the point alone (CrossingKind).
Crossing crossing(const LinearFit& first, const LinearFit& second);

// The two-sided t quantile for `confidence` and `df` degrees of freedom (Boost.Math).
double tQuantile(double confidence, int df);

// JSON as GET /api/crossover serves it (docs/api.md): a fit is {n, a, b,
// a_se, b_se, a_ci: [low, high], b_ci, r2, poor_fit, residual_se,
// min_pixels, max_pixels, points: [{pixels, value, residual}]}; a crossing is
// {kind, pixels, pixels_ci, resolution, resolution_ci, range, lower_below,
// lower_above, lower_throughout, ...} with names for the two sides.
nlohmann::json toJson(const LinearFit& fit);
nlohmann::json toJson(const Crossing& crossing, const std::string& firstName, const std::string& secondName);

}  // namespace tally::analysis

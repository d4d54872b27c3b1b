#include "analysis/crossover.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <boost/math/distributions/students_t.hpp>

namespace tally::analysis {

using nlohmann::json;

double tQuantile(double confidence, int df) {
  if (df < 1) return std::numeric_limits<double>::infinity();
  boost::math::students_t dist(static_cast<double>(df));
  return boost::math::quantile(dist, 0.5 + confidence / 2.0);
}

Result<LinearFit> fitLinear(const std::vector<double>& pixels, const std::vector<double>& values, double confidence) {
  if (pixels.size() != values.size()) {
    return makeError("pixel counts and values differ in number (" + std::to_string(pixels.size()) + " and " +
                     std::to_string(values.size()) + ")");
  }
  const size_t n = pixels.size();
  if (n < 3) {
    // Resolutions, not runs: two runs of one resolution are one resolution.
    std::vector<double> distinct = pixels;
    std::sort(distinct.begin(), distinct.end());
    distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
    std::string runs = distinct.size() == n ? "" : ", in " + std::to_string(n) + " runs";
    return makeError("a fit needs at least 3 resolutions, got " + std::to_string(distinct.size()) + runs +
                     " (with 2 the line passes through both points and has no error to state)");
  }
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(pixels[i]) || !std::isfinite(values[i])) {
      return makeError("point " + std::to_string(i) + " is not a finite number");
    }
  }
  double mx = 0, my = 0;
  for (size_t i = 0; i < n; ++i) {
    mx += pixels[i];
    my += values[i];
  }
  mx /= double(n);
  my /= double(n);
  double sxx = 0, sxy = 0, syy = 0;
  for (size_t i = 0; i < n; ++i) {
    double dx = pixels[i] - mx, dy = values[i] - my;
    sxx += dx * dx;
    sxy += dx * dy;
    syy += dy * dy;
  }
  auto [lo, hi] = std::minmax_element(pixels.begin(), pixels.end());
  if (*lo == *hi || sxx <= 0) {
    return makeError("every point has the same pixel count (" + std::to_string(static_cast<long long>(*lo)) +
                     "): the cost per pixel is undetermined; capture at least 2 different resolutions");
  }
  LinearFit f;
  f.n = static_cast<int>(n);
  f.confidence = confidence;
  f.minPixels = *lo;
  f.maxPixels = *hi;
  f.b = sxy / sxx;
  f.a = my - f.b * mx;
  double sse = 0;
  for (size_t i = 0; i < n; ++i) {
    double r = values[i] - (f.a + f.b * pixels[i]);
    sse += r * r;
    f.points.push_back({pixels[i], values[i], r});
  }
  const int df = f.n - 2;
  double s2 = sse / double(df);
  f.residualSe = std::sqrt(s2);
  f.bSe = std::sqrt(s2 / sxx);
  f.aSe = std::sqrt(s2 * (1.0 / double(n) + mx * mx / sxx));
  f.covAb = -mx * s2 / sxx;
  double t = tQuantile(confidence, df);
  f.aLow = f.a - t * f.aSe;
  f.aHigh = f.a + t * f.aSe;
  f.bLow = f.b - t * f.bSe;
  f.bHigh = f.b + t * f.bSe;
  f.r2 = syy > 0 ? 1.0 - sse / syy : 1.0;
  f.poor = f.r2 < kPoorFitR2;
  return f;
}

const char* crossingKindName(CrossingKind kind) {
  switch (kind) {
    case CrossingKind::Crosses: return "crosses";
    case CrossingKind::OutsideRange: return "outside_range";
    case CrossingKind::Parallel: return "parallel";
    case CrossingKind::NotSignificant: return "no_significant_crossing";
  }
  return "parallel";
}

std::optional<Resolution169> resolution169(double pixels) {
  if (!std::isfinite(pixels) || pixels <= 0) return std::nullopt;
  double height = std::round(std::sqrt(pixels * 9.0 / 16.0));
  if (height < 1) height = 1;
  if (height > 1e6) return std::nullopt;
  return Resolution169{static_cast<int>(std::round(height * 16.0 / 9.0)), static_cast<int>(height)};
}

FiellerInterval fiellerInterval(double n, double d, double varN, double varD, double cov, double t) {
  // (n - r d)^2 <= t^2 (varN - 2 r cov + r^2 varD), i.e. A r^2 - 2 B r + C <= 0.
  const double t2 = t * t;
  const double a = d * d - t2 * varD, b = n * d - t2 * cov, c = n * n - t2 * varN;
  FiellerInterval out;
  if (!(a > 0) || !std::isfinite(a) || !std::isfinite(b) || !std::isfinite(c)) return out;
  // The point n / d satisfies the inequality, so the discriminant is >= 0 but for rounding.
  const double root = std::sqrt(std::max(0.0, b * b - a * c));
  // The two roots without cancellation: q / a and c / q, q = b + sign(b) root.
  const double q = b + std::copysign(root, b);
  double r1 = q / a, r2 = q != 0 ? c / q : r1;
  if (q == 0) r1 = r2 = b / a;
  out.bounded = true;
  out.low = std::min(r1, r2);
  out.high = std::max(r1, r2);
  return out;
}

Crossing crossing(const LinearFit& first, const LinearFit& second) {
  Crossing c;
  c.confidence = first.confidence;
  c.rangeLow = std::max(first.minPixels, second.minPixels);
  c.rangeHigh = std::min(first.maxPixels, second.maxPixels);
  if (c.rangeLow > c.rangeHigh) {  // no overlap: the span of both
    c.rangeLow = std::min(first.minPixels, second.minPixels);
    c.rangeHigh = std::max(first.maxPixels, second.maxPixels);
  }
  c.degreesOfFreedom = first.n + second.n - 4;
  const double t = tQuantile(c.confidence, c.degreesOfFreedom);
  // Independent fits: the variances of the differences add.
  const double da = second.a - first.a;  // numerator
  const double db = first.b - second.b;  // denominator
  const double varDa = first.aSe * first.aSe + second.aSe * second.aSe;
  const double varDb = first.bSe * first.bSe + second.bSe * second.bSe;
  const double covDaDb = -first.covAb - second.covAb;  // cov(a2 - a1, b1 - b2)
  c.slopeDifference = db;
  c.slopeDifferenceSe = std::sqrt(varDb);
  auto valueAt = [](const LinearFit& f, double x) { return f.a + f.b * x; };
  const double middle = (c.rangeLow + c.rangeHigh) / 2.0;
  const int lowerAtMiddle = valueAt(first, middle) <= valueAt(second, middle) ? 0 : 1;

  // Exact fits (no residuals) have no error: slopes equal to rounding are parallel too.
  const double rounding = 1e-9 * std::max(std::abs(first.b), std::abs(second.b));
  if (std::abs(db) <= rounding || std::abs(db) <= t * c.slopeDifferenceSe) {
    c.kind = CrossingKind::Parallel;
    c.lowerBelow = c.lowerAbove = lowerAtMiddle;
    return c;
  }
  const double p = da / db;
  const double var = (varDa + p * p * varDb - 2.0 * p * covDaDb) / (db * db);
  c.pixels = p;
  c.pixelsSe = std::sqrt(std::max(0.0, var));
  c.deltaLow = p - t * *c.pixelsSe;
  c.deltaHigh = p + t * *c.pixelsSe;
  const FiellerInterval fieller = fiellerInterval(da, db, varDa, varDb, covDaDb, t);
  if (!fieller.bounded) {  // |db| > t se(db) makes it bounded; only rounding can land here
    c.kind = CrossingKind::Parallel;
    c.lowerBelow = c.lowerAbove = lowerAtMiddle;
    return c;
  }
  c.low = fieller.low;
  c.high = fieller.high;
  // Above the crossing the smaller slope is lower.
  c.lowerAbove = first.b < second.b ? 0 : 1;
  c.lowerBelow = 1 - c.lowerAbove;
  const bool inside = p >= c.rangeLow && p <= c.rangeHigh;
  const bool beyondBoth = *c.low < c.rangeLow && *c.high > c.rangeHigh;
  if (*c.high < c.rangeLow || *c.low > c.rangeHigh) {
    c.kind = CrossingKind::OutsideRange;
  } else if (inside && *c.low > 0 && !beyondBoth) {
    c.kind = CrossingKind::Crosses;
    return c;
  } else {
    c.kind = CrossingKind::NotSignificant;
    char level[16];
    std::snprintf(level, sizeof level, "%g%%", 100 * c.confidence);
    if (!inside) {
      c.why = std::string("the crossing is estimated outside the measured range, but its ") + level +
              " interval reaches into it";
    } else if (*c.low <= 0) {
      c.why = std::string("the ") + level + " interval of the crossing reaches 0 pixels or below";
    } else {
      c.why = std::string("the ") + level + " interval of the crossing extends beyond the measured range on both sides";
    }
  }
  c.lowerBelow = c.lowerAbove = lowerAtMiddle;
  return c;
}

namespace {

json resolutionJson(const std::optional<double>& pixels) {
  if (!pixels) return nullptr;
  auto r = resolution169(*pixels);
  if (!r) return nullptr;
  return {{"width", r->width}, {"height", r->height}};
}

}  // namespace

json toJson(const LinearFit& f) {
  json points = json::array();
  for (const auto& p : f.points) points.push_back({{"pixels", p.pixels}, {"value", p.value}, {"residual", p.residual}});
  return {{"n", f.n},
          {"a", f.a},
          {"b", f.b},
          {"a_se", f.aSe},
          {"b_se", f.bSe},
          {"a_ci", {f.aLow, f.aHigh}},
          {"b_ci", {f.bLow, f.bHigh}},
          {"residual_se", f.residualSe},
          {"r2", f.r2},
          {"poor_fit", f.poor},
          {"confidence", f.confidence},
          {"min_pixels", f.minPixels},
          {"max_pixels", f.maxPixels},
          {"points", points}};
}

json toJson(const Crossing& c, const std::string& firstName, const std::string& secondName) {
  const std::string names[2] = {firstName, secondName};
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  bool crosses = c.kind == CrossingKind::Crosses;
  bool throughout = c.kind == CrossingKind::OutsideRange || c.kind == CrossingKind::Parallel;
  json ci = c.low ? json{*c.low, *c.high} : json(nullptr);
  json deltaCi = c.deltaLow ? json{*c.deltaLow, *c.deltaHigh} : json(nullptr);
  json resolutionCi = nullptr;
  if (c.low) resolutionCi = json{resolutionJson(c.low), resolutionJson(c.high)};
  return {{"kind", crossingKindName(c.kind)},
          {"pixels", opt(c.pixels)},
          {"pixels_se", opt(c.pixelsSe)},
          {"pixels_ci", ci},
          {"pixels_ci_delta", deltaCi},
          {"resolution", resolutionJson(c.pixels)},
          {"resolution_ci", resolutionCi},
          {"range", {c.rangeLow, c.rangeHigh}},
          {"slope_difference", c.slopeDifference},
          {"slope_difference_se", c.slopeDifferenceSe},
          {"lower_below", crosses ? json(names[c.lowerBelow]) : json(nullptr)},
          {"lower_above", crosses ? json(names[c.lowerAbove]) : json(nullptr)},
          {"lower_throughout", throughout ? json(names[c.lowerBelow]) : json(nullptr)},
          {"significant", crosses || c.kind == CrossingKind::OutsideRange},
          {"why", c.why.empty() ? json(nullptr) : json(c.why)},
          {"confidence", c.confidence},
          {"degrees_of_freedom", c.degreesOfFreedom},
          {"interval_method", "fieller"}};
}

}  // namespace tally::analysis

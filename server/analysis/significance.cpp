#include "analysis/significance.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <utility>

#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>

namespace tally::analysis {
namespace {

// The exact distribution is built for samples up to this size (the counts of
// C(400, 200) ~ 1e119 still fit a double, and it costs m x m x n steps).
constexpr size_t kExactMax = 200;

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

Result<std::vector<double>> checked(const std::vector<double>& times, const char* name) {
  if (times.empty()) return makeError(std::string("sample ") + name + " is empty");
  if (times.size() < 2)
    return makeError(std::string("sample ") + name + " has 1 time; a comparison needs at least 2 in each sample");
  for (size_t i = 0; i < times.size(); ++i) {
    double t = times[i];
    if (!std::isfinite(t))
      return makeError(std::string("sample ") + name + ": time " + std::to_string(i) + " is not finite (" +
                       number(t) + ")");
    if (t <= 0)
      return makeError(std::string("sample ") + name + ": time " + std::to_string(i) + " is not positive (" +
                       number(t) + " ms)");
  }
  std::vector<double> sorted = times;
  std::sort(sorted.begin(), sorted.end());
  return sorted;
}

double medianOfSorted(const std::vector<double>& s) {
  size_t n = s.size();
  return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}

double normalQuantile(double p) { return boost::math::quantile(boost::math::normal(), p); }
double normalUpperTail(double z) { return boost::math::cdf(boost::math::complement(boost::math::normal(), z)); }

// Frequencies of U = 0..m*n for samples of m and n without ties: the
// coefficients of the Gaussian binomial [m+n choose m]_q, built as
// [n+i choose i]_q = [n+i-1 choose i-1]_q (1 - q^(n+i)) / (1 - q^i).
std::vector<double> uFrequencies(size_t m, size_t n) {
  std::vector<double> c(m * n + 1, 0.0);
  c[0] = 1;
  for (size_t i = 1; i <= m; ++i) {
    size_t top = i * n;  // the degree after this step
    for (size_t k = top; k >= n + i && k <= top; --k) c[k] -= c[k - n - i];
    for (size_t k = i; k <= top; ++k) c[k] += c[k - i];
  }
  return c;
}

// P(U <= u) for each u, from the frequencies.
std::vector<double> cumulative(const std::vector<double>& freq) {
  std::vector<double> cdf(freq.size());
  double total = 0;
  for (double f : freq) total += f;
  double run = 0;
  for (size_t k = 0; k < freq.size(); ++k) {
    run += freq[k];
    cdf[k] = std::min(1.0, run / total);
  }
  return cdf;
}

// Both samples, sorted, with the rank statistics every piece needs.
struct Prepared {
  std::vector<double> a, b;  // sorted times
  double u = 0;              // pairs with b > a, plus half the ties
  double greater = 0, less = 0;
  bool ties = false;
  double tieSum = 0;         // sum over tie groups of t^3 - t
  double mn() const { return double(a.size()) * double(b.size()); }
  double sigma() const {     // standard deviation of U under the null, tie-corrected
    double m = double(a.size()), n = double(b.size()), N = m + n;
    double v = m * n / 12.0 * ((N + 1) - tieSum / (N * (N - 1)));
    return std::sqrt(std::max(0.0, v));
  }
};

Result<Prepared> prepare(const std::vector<double>& a, const std::vector<double>& b) {
  auto sa = checked(a, "A");
  if (!sa) return makeError(sa.error());
  auto sb = checked(b, "B");
  if (!sb) return makeError(sb.error());
  Prepared p;
  p.a = std::move(*sa);
  p.b = std::move(*sb);
  // Pairs by merging the sorted samples: for each b_j, how many a_i lie below
  // it and how many equal it.
  size_t below = 0, upto = 0;
  for (double x : p.b) {
    while (below < p.a.size() && p.a[below] < x) ++below;
    upto = std::max(upto, below);
    while (upto < p.a.size() && p.a[upto] <= x) ++upto;
    p.greater += double(below);
    p.less += double(p.a.size() - upto);
  }
  double tied = p.mn() - p.greater - p.less;
  p.u = p.greater + 0.5 * tied;
  // Tie groups over the pooled sample.
  std::vector<double> pooled = p.a;
  pooled.insert(pooled.end(), p.b.begin(), p.b.end());
  std::sort(pooled.begin(), pooled.end());
  for (size_t i = 0; i < pooled.size();) {
    size_t j = i;
    while (j < pooled.size() && pooled[j] == pooled[i]) ++j;
    double t = double(j - i);
    if (t > 1) {
      p.ties = true;
      p.tieSum += t * t * t - t;
    }
    i = j;
  }
  return p;
}

Result<bool> useExact(const Prepared& p, PValueMethod method) {
  switch (method) {
    case PValueMethod::Normal: return false;
    case PValueMethod::Exact:
      if (p.ties) return makeError("the exact Mann-Whitney distribution assumes no ties, and the samples have tied times");
      if (p.a.size() > kExactMax || p.b.size() > kExactMax)
        return makeError("the exact Mann-Whitney distribution is built for samples of at most " +
                         std::to_string(kExactMax) + " times");
      return true;
    case PValueMethod::Automatic: break;
  }
  return !p.ties && p.a.size() < kExactBelow && p.b.size() < kExactBelow;
}

MannWhitney testOf(const Prepared& p, bool exact, const std::vector<double>* cdf) {
  MannWhitney t;
  t.u = p.u;
  t.ties = p.ties;
  t.exact = exact;
  double mean = p.mn() / 2, sigma = p.sigma(), dev = p.u - mean;
  double corrected = std::max(0.0, std::abs(dev) - 0.5);
  t.z = sigma > 0 ? std::copysign(corrected / sigma, dev) : 0.0;
  if (exact) {
    auto below = size_t(p.u);                  // an integer without ties
    auto above = size_t(p.mn() - p.u);         // P(U >= u) = P(U <= mn - u) by symmetry
    double tail = std::min((*cdf)[below], (*cdf)[above]);
    t.pValue = std::min(1.0, 2 * tail);
  } else {
    t.pValue = sigma > 0 ? std::min(1.0, 2 * normalUpperTail(std::abs(t.z))) : 1.0;
  }
  return t;
}

// Order-preserving map of doubles to unsigned integers (and back), for
// bisection over every double between two finite ones.
uint64_t orderedKey(double x) {
  auto u = std::bit_cast<uint64_t>(x);
  constexpr uint64_t sign = uint64_t(1) << 63;
  return (u & sign) ? ~u : (u | sign);
}
double fromKey(uint64_t k) {
  constexpr uint64_t sign = uint64_t(1) << 63;
  return std::bit_cast<double>((k & sign) ? (k & ~sign) : ~k);
}

// The pairwise differences lb[j] - la[i] of two sorted samples, without
// forming them: how many are <= t (O(m + n)), and the k-th smallest (1-based)
// as the smallest double t with at least k at or below it (64 bisections).
struct Differences {
  const std::vector<double>& la;
  const std::vector<double>& lb;

  double countAtMost(double t) const {
    size_t p = 0;
    double count = 0;
    for (double y : lb) {
      while (p < la.size() && y - la[p] > t) ++p;
      count += double(la.size() - p);
    }
    return count;
  }
  double kth(double k) const {
    uint64_t lo = orderedKey(lb.front() - la.back()), hi = orderedKey(lb.back() - la.front());
    while (lo < hi) {
      uint64_t mid = lo + (hi - lo) / 2;
      if (countAtMost(fromKey(mid)) >= k) hi = mid;
      else lo = mid + 1;
    }
    return fromKey(lo);
  }
};

struct LogInterval {
  RatioInterval interval;
  double logEstimate = 0, logLower = 0, logUpper = 0;
};

LogInterval intervalOf(const Prepared& p, double confidence, bool exact, const std::vector<double>* cdf) {
  std::vector<double> la(p.a.size()), lb(p.b.size());
  std::transform(p.a.begin(), p.a.end(), la.begin(), [](double x) { return std::log(x); });
  std::transform(p.b.begin(), p.b.end(), lb.begin(), [](double x) { return std::log(x); });
  Differences d{la, lb};
  auto mn = size_t(p.mn());
  LogInterval out;
  RatioInterval& r = out.interval;
  r.confidence = confidence;
  r.method = exact ? "hodges-lehmann-exact" : "hodges-lehmann-normal";
  out.logEstimate = mn % 2 ? d.kth(double(mn / 2 + 1)) : 0.5 * (d.kth(double(mn / 2)) + d.kth(double(mn / 2 + 1)));
  r.estimate = std::exp(out.logEstimate);

  // The rank k: the interval [D(k), D(mn + 1 - k)] misses a true shift with
  // probability 2 P(U <= k - 1) under the null distribution of U.
  double half = (1 - confidence) / 2;
  size_t k = 0;
  if (exact) {
    while (k < mn / 2 && (*cdf)[k] <= half) ++k;  // the largest k with P(U <= k - 1) <= alpha / 2
    r.achieved = k > 0 ? 1 - 2 * (*cdf)[k - 1] : 1.0;
  } else {
    double at = std::floor(p.mn() / 2 + 0.5 - normalQuantile(1 - half) * p.sigma());
    k = at >= 1 ? std::min(size_t(at), (mn + 1) / 2) : 0;
    r.achieved = confidence;
  }
  r.rank = k;
  r.bounded = k >= 1;
  if (r.bounded) {
    out.logLower = d.kth(double(k));
    out.logUpper = d.kth(double(mn + 1 - k));
    r.lower = std::exp(out.logLower);
    r.upper = std::exp(out.logUpper);
  } else {
    out.logLower = -std::numeric_limits<double>::infinity();
    out.logUpper = std::numeric_limits<double>::infinity();
    r.lower = 0;
    r.upper = std::numeric_limits<double>::infinity();
  }
  return out;
}

bool validConfidence(double c) { return std::isfinite(c) && c > 0 && c < 1; }

// Whether a x b < c x d for positive finite doubles, exactly: each product is
// split into its rounded value and the rounding error (p + e = a x b exactly,
// by a fused multiply-add), and rounding is monotone, so the rounded values
// decide unless they are equal, and then the errors do.
bool exactProductLess(double a, double b, double c, double d) {
  const double p = a * b, q = c * d;
  if (p != q) return p < q;
  return std::fma(a, b, -p) < std::fma(c, d, -q);
}

}  // namespace

double mannWhitneyCdf(size_t m, size_t n, double u) {
  if (m == 0 || n == 0 || m > kExactMax || n > kExactMax || std::isnan(u)) return std::nan("");
  if (u < 0) return 0;
  if (u >= double(m * n)) return 1;
  return cumulative(uFrequencies(m, n))[size_t(std::floor(u))];
}

EffectMagnitude cliffMagnitude(double delta) {
  double d = std::abs(delta);
  if (d < kCliffSmall) return EffectMagnitude::Negligible;
  if (d < kCliffMedium) return EffectMagnitude::Small;
  if (d < kCliffLarge) return EffectMagnitude::Medium;
  return EffectMagnitude::Large;
}

Result<MannWhitney> mannWhitney(const std::vector<double>& a, const std::vector<double>& b, PValueMethod method) {
  auto p = prepare(a, b);
  if (!p) return makeError(p.error());
  auto exact = useExact(*p, method);
  if (!exact) return makeError(exact.error());
  std::vector<double> cdf;
  if (*exact) cdf = cumulative(uFrequencies(p->a.size(), p->b.size()));
  return testOf(*p, *exact, &cdf);
}

Result<CliffsDelta> cliffsDelta(const std::vector<double>& a, const std::vector<double>& b) {
  auto p = prepare(a, b);
  if (!p) return makeError(p.error());
  CliffsDelta c;
  c.delta = (p->greater - p->less) / p->mn();
  c.magnitude = cliffMagnitude(c.delta);
  return c;
}

Result<RatioInterval> ratioInterval(const std::vector<double>& a, const std::vector<double>& b, double confidence,
                                    PValueMethod method) {
  if (!validConfidence(confidence)) return makeError("confidence must lie strictly between 0 and 1");
  auto p = prepare(a, b);
  if (!p) return makeError(p.error());
  auto exact = useExact(*p, method);
  if (!exact) return makeError(exact.error());
  std::vector<double> cdf;
  if (*exact) cdf = cumulative(uFrequencies(p->a.size(), p->b.size()));
  return intervalOf(*p, confidence, *exact, &cdf).interval;
}

Result<double> acrossCaptureLogSd(const std::vector<double>& perRunMedians) {
  std::vector<double> logs;
  for (double v : perRunMedians) {
    if (!std::isfinite(v) || v <= 0) return makeError("a run median is not a positive finite time (" + number(v) + ")");
    logs.push_back(std::log(v));
  }
  if (logs.size() < 2) return 0.0;
  double mean = 0;
  for (double l : logs) mean += l;
  mean /= double(logs.size());
  double ss = 0;
  for (double l : logs) ss += (l - mean) * (l - mean);
  return std::sqrt(ss / double(logs.size() - 1));
}

double acrossCaptureHalfWidth(double acrossLogSd, size_t runs, double confidence) {
  if (!(acrossLogSd > 0) || !validConfidence(confidence)) return 0;
  double p = 1 - (1 - confidence) / 2;
  double q = runs >= 2 ? boost::math::quantile(boost::math::students_t(double(runs - 1)), p) : normalQuantile(p);
  return q * std::sqrt(2.0) * acrossLogSd;
}

Result<TimeComparison> compareTimes(const std::vector<double>& a, const std::vector<double>& b,
                                    const CompareOptions& options) {
  if (!validConfidence(options.confidence)) return makeError("confidence must lie strictly between 0 and 1");
  if (!std::isfinite(options.practicalThreshold) || options.practicalThreshold < 0)
    return makeError("the practical threshold must be a finite number >= 0");
  if (!std::isfinite(options.acrossCaptureLogSd) || options.acrossCaptureLogSd < 0)
    return makeError("the across-capture spread must be a finite number >= 0");
  auto p = prepare(a, b);
  if (!p) return makeError(p.error());
  auto exact = useExact(*p, options.pValueMethod);
  if (!exact) return makeError(exact.error());
  std::vector<double> cdf;
  if (*exact) cdf = cumulative(uFrequencies(p->a.size(), p->b.size()));

  TimeComparison c;
  c.nA = p->a.size();
  c.nB = p->b.size();
  c.medianA = medianOfSorted(p->a);
  c.medianB = medianOfSorted(p->b);
  c.ratio = c.medianB / c.medianA;
  c.alpha = 1 - options.confidence;
  c.practicalThreshold = options.practicalThreshold;
  c.test = testOf(*p, *exact, &cdf);
  c.effect.delta = (p->greater - p->less) / p->mn();
  c.effect.magnitude = cliffMagnitude(c.effect.delta);

  LogInterval li = intervalOf(*p, options.confidence, *exact, &cdf);
  c.interval = li.interval;
  if (c.interval.bounded && options.acrossCaptureLogSd > 0) {
    // Across-capture noise (docs/statistics.md): the frames' interval and
    // that of the difference of two captures' medians are independent
    // sources of error, so their half-widths add as variances, each side on
    // its own (the frames' asymmetry is kept).
    double across = acrossCaptureHalfWidth(options.acrossCaptureLogSd, options.acrossCaptureRuns, options.confidence);
    double below = li.logEstimate - li.logLower, above = li.logUpper - li.logEstimate;
    double lower = li.logEstimate - std::hypot(below, across), upper = li.logEstimate + std::hypot(above, across);
    double within = li.logUpper - li.logLower;
    c.interval.widening = within > 0 ? (upper - lower) / within : std::numeric_limits<double>::infinity();
    c.interval.lower = std::exp(lower);
    c.interval.upper = std::exp(upper);
  }

  std::string level = number(100 * options.confidence) + "%";
  std::string interval = "[" + number(c.interval.lower) + ", " + number(c.interval.upper) + "]";
  std::string pv = "p = " + number(c.test.pValue);
  if (!(c.test.pValue < c.alpha)) {
    c.reason = pv + " >= alpha = " + number(c.alpha);
  } else if (!c.interval.bounded) {
    c.reason = pv + " but the samples are too small for a " + level + " interval";
  } else if (!(c.interval.lower >= 1 && c.interval.upper > 1) && !(c.interval.upper <= 1 && c.interval.lower < 1)) {
    // An end may be exactly 1 when times are tied (a pairwise difference of
    // 0): the test, which counts tied pairs as half, decides there.
    c.reason = pv + " < alpha but the " + level + " interval " + interval + " reaches both sides of 1" +
               (c.interval.widening > 1 ? " (widened for across-capture noise)" : "");
  } else if (options.practicalThreshold > 0 && !(std::abs(c.ratio - 1) > options.practicalThreshold)) {
    c.reason = pv + " < alpha but |ratio - 1| = " + number(std::abs(c.ratio - 1)) + " <= the practical threshold " +
               number(options.practicalThreshold);
  } else {
    bool slower = c.interval.lower >= 1;
    c.verdict = slower ? Verdict::Slower : Verdict::Faster;
    c.reason = pv + " < alpha = " + number(c.alpha) + " and the " + level + " interval " + interval + " lies " +
               (slower ? "above" : "below") + " 1";
  }
  return c;
}

CountComparison compareCounts(double a, double b) {
  CountComparison c;
  c.verdict = a == b ? CountVerdict::Same : CountVerdict::Changed;
  c.delta = b - a;
  return c;
}

const char* toString(Verdict v) {
  switch (v) {
    case Verdict::Faster: return "faster";
    case Verdict::Slower: return "slower";
    case Verdict::Same: break;
  }
  return "same";
}

const char* toString(EffectMagnitude m) {
  switch (m) {
    case EffectMagnitude::Small: return "small";
    case EffectMagnitude::Medium: return "medium";
    case EffectMagnitude::Large: return "large";
    case EffectMagnitude::Negligible: break;
  }
  return "negligible";
}

const char* toString(CountVerdict v) { return v == CountVerdict::Changed ? "changed" : "same"; }

Result<AlignedSamples> alignStrata(const std::vector<Stratum>& strata) {
  if (strata.empty()) return makeError("no strata to align");
  std::vector<double> all;
  for (size_t s = 0; s < strata.size(); ++s) {
    if (strata[s].a.empty() || strata[s].b.empty()) {
      return makeError("stratum " + std::to_string(s) + " has no time in sample " + (strata[s].a.empty() ? "A" : "B"));
    }
    for (const auto* times : {&strata[s].a, &strata[s].b}) {
      for (size_t i = 0; i < times->size(); ++i) {
        double v = (*times)[i];
        if (!std::isfinite(v) || v <= 0) {
          return makeError("stratum " + std::to_string(s) + ", sample " + (times == &strata[s].a ? "A" : "B") +
                           ": time " + std::to_string(i) + (std::isfinite(v) ? " is not positive (" : " is not finite (") +
                           number(v) + " ms)");
        }
      }
      all.insert(all.end(), times->begin(), times->end());
    }
  }
  std::sort(all.begin(), all.end());
  const double grand = medianOfSorted(all);
  // Every time with its stratum's median: the aligned time is exactly
  // time x grand / median, and the order of two aligned times is the order
  // of time / median, which compares exactly as time_i x median_j against
  // time_j x median_i (exactProductLess). Rounding time x (grand / median)
  // can make two different exact values one double (x (g / x) != g): a tie
  // the raw frames do not have, which turns the exact test into the normal
  // one; or reverse two close values. The doubles are therefore placed in
  // the exact order: equal where the exact values are equal, strictly
  // increasing where they differ, each within a few units in the last place
  // of its rounded product.
  struct Entry {
    double time, median, aligned;
    bool isA;
    size_t position;
  };
  std::vector<Entry> entries;
  AlignedSamples out;
  for (const auto& stratum : strata) {
    std::vector<double> both(stratum.a);
    both.insert(both.end(), stratum.b.begin(), stratum.b.end());
    std::sort(both.begin(), both.end());
    const double median = medianOfSorted(both);
    const double factor = grand / median;
    for (double v : stratum.a) {
      entries.push_back({v, median, v * factor, true, out.a.size()});
      out.a.push_back(v * factor);
    }
    for (double v : stratum.b) {
      entries.push_back({v, median, v * factor, false, out.b.size()});
      out.b.push_back(v * factor);
    }
  }
  auto less = [](const Entry& x, const Entry& y) { return exactProductLess(x.time, y.median, y.time, x.median); };
  std::sort(entries.begin(), entries.end(), less);
  for (size_t i = 0; i < entries.size(); ++i) {
    Entry& e = entries[i];
    if (i > 0) {
      const Entry& prev = entries[i - 1];
      if (!less(prev, e)) {
        e.aligned = prev.aligned;  // equal exact values: a true tie
      } else if (!(e.aligned > prev.aligned)) {
        e.aligned = std::nextafter(prev.aligned, std::numeric_limits<double>::infinity());
      }
    }
    (e.isA ? out.a : out.b)[e.position] = e.aligned;
  }
  return out;
}

nlohmann::json toJson(const TimeComparison& c) {
  auto end = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"n_a", c.nA},
          {"n_b", c.nB},
          {"median_a", c.medianA},
          {"median_b", c.medianB},
          {"ratio", c.ratio},
          {"interval",
           {{"estimate", c.interval.estimate},
            {"lower", end(c.interval.lower)},
            {"upper", end(c.interval.upper)},
            {"confidence", c.interval.confidence},
            {"achieved", c.interval.achieved},
            {"bounded", c.interval.bounded},
            {"method", c.interval.method},
            {"widening", end(c.interval.widening)}}},
          {"mann_whitney",
           {{"u", c.test.u},
            {"z", c.test.z},
            {"p", c.test.pValue},
            {"method", c.test.exact ? "exact" : "normal"},
            {"ties", c.test.ties}}},
          {"cliffs_delta", {{"delta", c.effect.delta}, {"magnitude", toString(c.effect.magnitude)}}},
          {"alpha", c.alpha},
          {"practical_threshold", c.practicalThreshold},
          {"verdict", toString(c.verdict)},
          {"reason", c.reason}};
}

nlohmann::json toJson(const CountComparison& c) {
  return {{"verdict", toString(c.verdict)}, {"delta", c.delta}};
}

}  // namespace tally::analysis

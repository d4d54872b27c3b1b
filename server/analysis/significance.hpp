// Whether a difference between two runs is real: frame or pass times of run A
// against run B (ratio of medians, a distribution-free confidence interval for
// the ratio, the Mann-Whitney test, Cliff's delta and a verdict), and counters,
// which are deterministic and compare exactly. Pure functions over plain
// numbers; docs/statistics.md states the methods, their assumptions and the
// rates measured by tests/analysis/significance_test.cpp.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"

namespace tally::analysis {

enum class Verdict { Same, Faster, Slower };          // B against A: Faster when B takes less time
enum class PValueMethod { Automatic, Exact, Normal };  // how the Mann-Whitney p-value is found
enum class EffectMagnitude { Negligible, Small, Medium, Large };

// Cliff's |delta| thresholds (Romano et al. 2006): below 0.147 negligible,
// below 0.33 small, below 0.474 medium, else large.
inline constexpr double kCliffSmall = 0.147;
inline constexpr double kCliffMedium = 0.33;
inline constexpr double kCliffLarge = 0.474;

// Automatic uses the exact distribution when both samples are smaller than
// this and there are no ties, the normal approximation otherwise.
inline constexpr size_t kExactBelow = 50;

struct CompareOptions {
  double confidence = 0.95;        // of the interval; the test's level is alpha = 1 - confidence
  double practicalThreshold = 0;   // a verdict other than Same also needs |ratio - 1| > this (0: significance only)
  PValueMethod pValueMethod = PValueMethod::Automatic;  // Exact with tied times is an error
  // Across-capture noise: the standard deviation of log(run median) over
  // repeated captures of one configuration (acrossCaptureLogSd below) and the
  // number of captures it came from; 0 when unknown. The interval is widened
  // by the across-capture one: their log half-widths add as variances, each
  // side on its own (docs/statistics.md, "Across-capture noise").
  double acrossCaptureLogSd = 0;
  size_t acrossCaptureRuns = 0;  // Student's t with runs - 1 degrees of freedom; below 2: the normal quantile
};

struct MannWhitney {
  double u = 0;       // pairs (a_i, b_j) with b_j > a_i, plus half of the tied pairs; 0..m*n
  double z = 0;       // the normal approximation's z (continuity- and tie-corrected); also given when exact
  double pValue = 1;  // two-sided
  bool exact = false; // true: the exact distribution of U (no ties); false: the normal approximation
  bool ties = false;  // some time occurs in both samples or twice in one
};

struct CliffsDelta {
  double delta = 0;   // (#{b_j > a_i} - #{b_j < a_i}) / (m*n), in [-1, 1]; > 0: B tends to take longer
  EffectMagnitude magnitude = EffectMagnitude::Negligible;
};

// A confidence interval for the ratio B/A: the Hodges-Lehmann shift of log
// times, exp'd. Unbounded (lower 0, upper +inf) when the samples are too small
// for the level (e.g. 3 and 3 at 95%).
struct RatioInterval {
  double estimate = 1;   // exp(median over all pairs of log b_j - log a_i)
  double lower = 0, upper = 0;
  double confidence = 0;   // nominal level asked for
  double achieved = 0;     // exact method: the interval's exact coverage under the shift model (>= confidence); normal: = confidence
  size_t rank = 0;         // the interval is [D(rank), D(m*n + 1 - rank)] of the sorted pairwise log differences; 0: unbounded
  bool bounded = false;
  std::string method;      // "hodges-lehmann-exact" | "hodges-lehmann-normal"
  double widening = 1;     // the log-scale width over the frames' own after across-capture noise (1: none; +inf: the frames' interval had zero width)
};

struct TimeComparison {
  size_t nA = 0, nB = 0;
  double medianA = 0, medianB = 0;  // ms
  double ratio = 1;                 // medianB / medianA
  RatioInterval interval;
  MannWhitney test;
  CliffsDelta effect;
  double alpha = 0.05;               // 1 - confidence
  double practicalThreshold = 0;
  Verdict verdict = Verdict::Same;
  std::string reason;                // one line saying why the verdict is what it is
};

// Compares two samples of positive, finite times (ms), e.g. per-frame times
// of run A and run B pooled over cameras. Each sample needs at least 2 times.
// Verdict rule: Faster/Slower when p < alpha, the interval (widened, where
// across-capture noise is given) lies on one side of 1 (an end may be exactly
// 1 where tied times make a pairwise difference 0), and |ratio - 1| >
// practicalThreshold; the direction is the interval's side of 1.
Result<TimeComparison> compareTimes(const std::vector<double>& a, const std::vector<double>& b,
                                    const CompareOptions& options = {});

// Times in strata (a run's cameras): camera-to-camera differences in time
// dwarf a few percent between two renderers, and pooled over cameras they
// make the test blind to a consistent difference. Aligning removes them: each
// stratum's times, of both samples, are multiplied by M / m_s, where m_s is
// the median of that stratum's A and B times together and M the median of all
// times together. A ratio common to every stratum survives the alignment;
// under no difference a stratum's times stay exchangeable between A and B,
// since m_s is a function of the stratum's times as a set
// (docs/statistics.md, "Cameras as strata"). The aligned doubles keep the
// order and the ties of the exact values time x M / m_s: rounding creates no
// tie the exact values lack, and keeps every one they have. Returns the
// aligned A and B, pooled in stratum order. Errors as compareTimes's for a non-positive or
// non-finite time, or a stratum with no time in A or in B.
struct Stratum {
  std::vector<double> a, b;
};
struct AlignedSamples {
  std::vector<double> a, b;
};
Result<AlignedSamples> alignStrata(const std::vector<Stratum>& strata);

// The pieces on their own (same checks on the times as compareTimes).
Result<MannWhitney> mannWhitney(const std::vector<double>& a, const std::vector<double>& b,
                                PValueMethod method = PValueMethod::Automatic);
Result<CliffsDelta> cliffsDelta(const std::vector<double>& a, const std::vector<double>& b);
Result<RatioInterval> ratioInterval(const std::vector<double>& a, const std::vector<double>& b,
                                    double confidence = 0.95, PValueMethod method = PValueMethod::Automatic);

// The exact null distribution of U for samples of m and n without ties:
// P(U <= u). m and n at most 200 (beyond, use the normal approximation).
double mannWhitneyCdf(size_t m, size_t n, double u);

EffectMagnitude cliffMagnitude(double delta);

// Across-capture noise from repeated captures of one configuration: the
// sample standard deviation of log(median) over the runs (e.g.
// RepeatFigure::perRun from analysis/repeats.hpp); 0 with fewer than 2 runs.
// Error for non-positive or non-finite medians.
Result<double> acrossCaptureLogSd(const std::vector<double>& perRunMedians);

// The half-width on the log scale of an interval for the difference of two
// captures' medians when each capture's log median varies with standard
// deviation acrossLogSd, estimated from `runs` captures: q x sqrt(2) x
// acrossLogSd, q the two-sided quantile of Student's t with runs - 1 degrees
// of freedom (the normal's when runs < 2). compareTimes widens each of its
// interval's log half-widths h to sqrt(h^2 + this^2).
double acrossCaptureHalfWidth(double acrossLogSd, size_t runs, double confidence);

// Counts are deterministic: equal or not, no test.
enum class CountVerdict { Same, Changed };
struct CountComparison {
  CountVerdict verdict = CountVerdict::Same;
  double delta = 0;  // b - a
};
CountComparison compareCounts(double a, double b);

const char* toString(Verdict v);           // "faster" | "slower" | "same"
const char* toString(EffectMagnitude m);   // "negligible" | "small" | "medium" | "large"
const char* toString(CountVerdict v);      // "same" | "changed"

// For the API: the fields above in snake_case (n_a, median_a, ratio,
// interval, mann_whitney {u, z, p, method "exact" | "normal", ties},
// cliffs_delta {delta, magnitude}, alpha, practical_threshold, verdict,
// reason); an infinite interval end or widening is null (JSON has no
// infinity).
nlohmann::json toJson(const TimeComparison& c);
nlohmann::json toJson(const CountComparison& c);

}  // namespace tally::analysis

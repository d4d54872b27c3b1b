// Whether two stored runs differ: their frame and pass times with the tests of
// analysis/significance.hpp over per-frame times pooled across the cameras both
// runs measured, widened by the across-capture noise of repeated captures
// where the store has them, and their counts compared exactly. The compare
// route and the alert evaluator call it; docs/statistics.md, "Comparing two
// stored runs", states the rules.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/significance.hpp"
#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::reports {

// Repeated captures of one configuration taken into account at most (the
// newest first).
inline constexpr size_t kMaxAcrossCaptureRepeats = 20;

// Fewer repeated captures of a configuration than this leave the
// capture-to-capture noise poorly bounded, and the verdict says so.
inline constexpr size_t kMinCapturesToBoundNoise = 3;

// The across-capture noise every figure was widened by: the spread of the
// repeats' log medians within each (configuration, camera, figure) cell,
// pooled over the cells.
struct AcrossCapture {
  std::vector<int64_t> runs;  // the repeats whose medians gave it (both runs' configurations)
  double logSd = 0;           // pooled standard deviation of log(per-camera median)
  size_t degreesOfFreedom = 0;  // sum over the cells of (captures in the cell - 1)
  size_t cells = 0;             // (configuration, camera, figure) cells with 2 captures or more
  size_t captures = 0;          // the most captures of one configuration
};

struct FigureSignificance {
  std::string figure;  // "frame" or the pass's name
  // Over the cameras' frames aligned (analysis::alignStrata) when the
  // cameras were strata: then the medians and ratio are of aligned times.
  analysis::TimeComparison time;
  bool camerasAsStrata = true;
  // The median of each run's raw times pooled over the shared cameras, not
  // aligned: the runs' frame_ms_median (reports/frame_time.hpp) when they
  // share every camera, whatever the strata.
  std::optional<double> runMedianA, runMedianB;
  std::optional<AcrossCapture> acrossCapture;  // absent: no configuration had 2 comparable captures
  // Set, and appended to time.reason, when across-capture noise was sought
  // but the repeats are too few to bound it (fewer than
  // kMinCapturesToBoundNoise captures, or none).
  std::string noiseNote;
};

struct CountChange {
  std::string line;  // "total" (the sample bytes) or "pass/resource access" (its count)
  double a = 0, b = 0;  // per frame: the mean over the shared cameras (compared as sums, exactly)
};

struct RunSignificance {
  int64_t runA = 0, runB = 0;
  // Set (and nothing else) when the runs share no camera: then there is
  // nothing to compare.
  std::string incomparable;
  std::vector<std::string> cameras;  // camera keys both runs measured; frames are pooled over these
  // Absent when a shared camera of either run has no per-frame times stored
  // (runs ingested before they were kept) or a stored time is not positive,
  // with the reason in frameMissing.
  std::optional<FigureSignificance> frame;
  std::string frameMissing;
  std::vector<FigureSignificance> passes;  // passes of both runs with per-frame times, in run A's order
  std::vector<std::pair<std::string, std::string>> passesMissing;  // passes of both runs not compared, and why
  size_t countLines = 0;                   // lines compared, "total" included
  std::vector<CountChange> countChanges;   // every line whose count differs (==, no tolerance)
  bool countsChanged() const { return !countChanges.empty(); }
};

struct SignificanceOptions {
  analysis::CompareOptions compare;  // confidence and practical threshold; its across-capture fields are set here
  bool acrossCapture = true;         // look for repeated captures of both configurations
  // Each camera a stratum: its frames aligned on their median before pooling
  // (the default); false pools the raw frames, and camera-to-camera spread
  // then hides differences of a few percent (docs/statistics.md).
  bool camerasAsStrata = true;
};

// A run's samples by camera key; a second sample of an equal camera gets "#2".
using Samples = std::map<std::string, store::Sample>;

// A stored run with its samples, loaded once for every comparison it is in.
struct StoredRun {
  store::Run run;
  Samples samples;
};

// Nullopt when there is no such run.
Result<std::optional<StoredRun>> loadStoredRun(store::Store& store, int64_t id);

// Errors: a run that does not exist, a store error. Runs without a camera in
// common are answered with `incomparable` set.
Result<RunSignificance> runSignificance(store::Store& store, int64_t runA, int64_t runB,
                                        const SignificanceOptions& options = {});
// The same over runs already loaded (the store is read for their repeats).
Result<RunSignificance> runSignificance(store::Store& store, const StoredRun& a, const StoredRun& b,
                                        const SignificanceOptions& options = {});

nlohmann::json toJson(const RunSignificance& s);

}  // namespace tally::reports

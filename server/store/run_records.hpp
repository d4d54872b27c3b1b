// The store's run records: devices, runs, samples with their passes and
// counters, sweeps, comparisons and export rows, and the page and cursor every
// list takes. What the Runs facet (runs.hpp) reads and writes; kept apart so
// that code reading stored results needs no Store.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/frame_time.hpp"

namespace tally::store {

// ---- runs, samples ------------------------------------------------------------

struct Device {
  int64_t id = 0;
  std::string name, vendor, driver, apiVersion;
  nlohmann::json features;  // the result's device.features
  nlohmann::json info;      // the whole device object
};

struct RunFilter {
  std::optional<std::string> renderer;
  std::optional<std::string> variant;  // exact variant label ("visbuffer barycentrics=float32")
  std::optional<std::string> scene;  // scene name
  std::optional<int> width;
  std::optional<int> height;
  std::optional<int64_t> deviceId;
  std::optional<std::string> deviceName;  // exact device name
  std::optional<int64_t> jobId;
  std::optional<std::string> host;  // exact host name
  // Every one of these labels (name, value), exactly (0009): the capture's spec "labels".
  std::vector<std::pair<std::string, std::string>> labels;
  std::vector<int64_t> runIds;  // any of these runs (at most 1000); empty: any run
  // Creation time bounds, as prefixes of the stored UTC ISO-8601 text
  // ("2026-11-21", "2026-11-21T06:30"): since is compared with created_at,
  // until with created_at cut to its length, so both ends are inclusive at the
  // precision given (until=2026-11-21 keeps the whole day).
  std::optional<std::string> createdSince;
  std::optional<std::string> createdUntil;
};

struct Page {
  int limit = 100;     // 1..1000
  std::string cursor;  // empty: first page; else a nextCursor from the previous page
};

struct RunRow {
  int64_t id = 0;
  int64_t jobId = 0;
  int64_t deviceId = 0;
  std::string deviceName;
  std::string renderer;
  std::string scene;
  nlohmann::json sceneParams;
  int width = 0, height = 0;
  std::string counting;
  int lights = 0;
  std::optional<int64_t> renderTargetBytes;
  nlohmann::json notes;
  std::string createdAt;
  int sampleCount = 0;
  std::optional<double> meanFrameMs;  // over the run's samples
  std::optional<double> meanBytes;    // all counters per frame, over the run's samples
  std::optional<double> meanFrameMsInstrumented;  // a counted frame, over the samples
  std::optional<double> meanOverheadRatio;        // instrumented / uninstrumented frame time, over the samples
  // Image error against the reference (forward) over the samples compared:
  // how many were compared and how many were identical; PSNR (dB) over those
  // that differ, absent when none differs.
  int imageCompared = 0;
  int imageIdentical = 0;
  std::optional<double> meanPsnr;
  std::optional<double> minPsnr;
  // The renderer's canonical options ({} for the renderer as it is) and the
  // variant's label; runs stored before variants are their renderer.
  nlohmann::json options = nlohmann::json::object();
  std::string variant;
  // The Tally build that made the run; absent for runs stored before 0005.
  std::optional<std::string> tallyVersion, tallyCommit;
  // Footprint (0006): the block size the run counted it in (absent: off, or
  // stored before), and over the samples that have one, the mean footprint
  // per frame and the mean requested bytes of the lines that have a footprint
  // (reuse = footprintRequested / footprint). Absent when no sample has one.
  std::optional<int64_t> footprintBlockBytes;
  std::optional<double> meanFootprintBytes, meanFootprintRequestedBytes;
  std::optional<std::string> host;  // the host it was captured on (0007); absent before
  nlohmann::json labels = nlohmann::json::object();  // its capture's labels (0009); {} for none
  // The run's frame time as the ingest computed it (0013); absent for runs
  // stored before, whose readers compute it from the samples
  // (reports::frameTimesOf).
  std::optional<RunFrameTime> frameTime;
};

struct RunPage {
  std::vector<RunRow> runs;  // newest first (descending id)
  std::string nextCursor;    // empty when this was the last page
};

struct RunResource {
  std::string name, kind;
  std::optional<std::string> format;
  std::optional<int64_t> elementBytes, width, height, allocationBytes, formatBytes;
  std::optional<std::string> usage;
};

struct Run {
  RunRow row;
  Device device;
  std::vector<RunResource> resources;  // in the result's order
  nlohmann::json shaders;              // shader source hashes of the capture
  nlohmann::json counterHeadroom;      // the result's counter_headroom; null when not stored
  // The device's ceilings measured by the run's capture (its samples'
  // extras.roofline.ceilings); null when not measured or not stored.
  nlohmann::json ceilings;
};

struct ImageError {
  std::string against;
  bool identical = false;
  std::optional<double> psnr;  // absent when identical
  double maxAbs = 0, meanAbs = 0;
};

struct SampleRow {
  int64_t id = 0;
  int64_t runId = 0;
  int cameraIndex = 0;
  nlohmann::json camera;
  std::optional<double> skyFraction;  // absent when the renderer has no skybox pass
  std::optional<double> skyFractionEstimate;
  std::optional<int> frames;
  double frameMs = 0;
  nlohmann::json frameMsSpread;  // null when absent
  std::optional<double> frameMsInstrumented;
  std::optional<double> overheadRatio;
  double bytes = 0;  // all counters of the sample, per frame
  double bytesRead = 0, bytesWritten = 0;  // its read and write counters, per frame
  std::optional<ImageError> imageError;
  bool hasScreenshot = false;
  nlohmann::json extras = nlohmann::json::object();  // technique measurements of the sample
  std::optional<ImageError> variantError;  // against the run's reference variant
  // The footprint of the sample's lines that have one, and those lines'
  // requested bytes, per frame; absent when no line has a footprint.
  std::optional<double> footprintBytes, footprintRequestedBytes;
  // Every uninstrumented frame's time (ms), in frame order (0008): filled by
  // sample() only; empty when not stored (older rows, results without it).
  std::vector<double> frameMsFrames;
};

struct Counter {
  std::string resource;
  std::optional<std::string> kind, format;
  std::string access;  // read | write
  double count = 0;    // per frame
  double bytes = 0;    // per frame
  nlohmann::json countSpread;
  std::string source;  // counter | derived
  std::optional<double> footprintBytes;  // distinct bytes touched per frame; absent where not measured
};

struct Pass {
  std::string name;
  double gpuMs = 0;
  nlohmann::json gpuMsSpread;
  std::optional<double> gpuMsInstrumented;
  std::optional<double> overheadRatio;
  std::optional<double> fragmentInvocations;
  std::optional<double> fragmentInvocationsStatistic;
  std::vector<Counter> counters;  // in the result's order
  // Passes that dispatch compute work; empty for the others.
  std::optional<double> computeInvocations;
  std::optional<double> computeInvocationsStatistic;
  // The pass's time (ms) in each of the sample's uninstrumented frames, in
  // frame order (0008): filled by sample() only; empty when not stored.
  std::vector<double> gpuMsFrames;
};

struct Sample {
  SampleRow row;
  std::vector<Pass> passes;  // in frame order
};

// A run and its passes averaged over its samples (Runs::detail).
struct RunDetail {
  Run run;
  std::vector<Pass> passes;
};

// ---- sweeps --------------------------------------------------------------------

struct SweepFilter {
  std::optional<std::string> name;  // the sweep's name, e.g. "depth-reconstruction"
  std::optional<int64_t> deviceId;
  std::optional<std::string> deviceName;  // exact device name
  std::optional<int64_t> jobId;
  // As RunFilter's: prefixes of the stored UTC ISO-8601 text, both inclusive.
  std::optional<std::string> createdSince;
  std::optional<std::string> createdUntil;
};

struct SweepRow {
  int64_t id = 0;
  int64_t jobId = 0;
  Device device;
  std::string name;
  nlohmann::json parameters;  // array of axis names
  nlohmann::json threshold;   // as the result gave it
  nlohmann::json failsAt;     // null when no point reaches the threshold
  int64_t pointCount = 0;
  std::string createdAt;
};

struct SweepPage {
  std::vector<SweepRow> sweeps;  // newest first (descending id)
  std::string nextCursor;        // empty when this was the last page
};

struct Sweep {
  SweepRow row;
  nlohmann::json result;  // the whole result, as ingested
};

// ---- compare, export ----------------------------------------------------------

// One quantity for one run, against the first run of the comparison.
struct Compared {
  std::optional<double> value;  // absent when the run does not have this pass/resource
  std::optional<double> delta;  // value - first's value (both present)
  std::optional<double> ratio;  // value / first's value (both present, first non-zero)
};

// Values are per frame, averaged over the run's samples (a sample without the
// pass/resource counts as 0); one entry per compared run, in the order asked.
struct PassComparison {
  std::string pass;
  std::vector<Compared> gpuMs;
  std::vector<Compared> bytes;  // all of the pass's counters (requested bytes)
  std::vector<Compared> fragmentInvocations;
  // The footprint of the counters that have one (absent for a run without),
  // and reuse: those counters' requested bytes / their footprint.
  std::vector<Compared> footprintBytes;
  std::vector<Compared> reuse;
};

struct ResourceComparison {
  std::string resource;
  std::string access;  // read | write
  std::vector<Compared> count;
  std::vector<Compared> bytes;  // summed over passes (requested bytes)
  std::vector<Compared> footprintBytes;  // summed over passes; absent for a run without
  std::vector<Compared> reuse;           // as PassComparison's
};

struct Comparison {
  std::vector<RunRow> runs;
  std::vector<Compared> frameMs;
  std::vector<Compared> totalBytes;
  std::vector<Compared> totalFootprintBytes;  // every counter that has one; absent for a run without
  std::vector<Compared> reuse;                // those counters' requested bytes / their footprint
  std::vector<PassComparison> passes;         // first run's frame order, then others' new passes
  std::vector<ResourceComparison> resources;  // by resource name, then access
};

// One row per run x pass x resource x access; count and bytes per frame,
// averaged over the run's samples.
struct ExportRow {
  int64_t runId = 0;
  std::string renderer, scene;
  int width = 0, height = 0;
  std::string device, pass, resource, access;
  double count = 0, bytes = 0;
  // The footprint of the row's counters that have one, and their requested
  // bytes (reuse = footprintRequestedBytes / footprintBytes); absent without.
  std::optional<double> footprintBytes, footprintRequestedBytes;
};

// Cursor encoding for the lists of runs, sweeps, jobs and alerts ("r" + last id in hex; opaque to clients).
std::string encodeCursor(int64_t lastId);
std::optional<int64_t> decodeCursor(std::string_view cursor);

}  // namespace tally::store

// Each run's summary over its samples (migration 0013), computed at ingest
// from the values read for the samples' own rows, and written on the run's
// row with it: no statement re-reads the samples (ingest_input.hpp).
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include "store/ingest_input.hpp"

namespace tally::store::detail {

using nlohmann::json;
using json_fields::find;

namespace {

// The camera's index within its run, refused when an earlier sample of the
// run has it (the samples table keeps one sample per camera and run).
int64_t cameraIndexOf(const json& camera, size_t s, const std::string& at, std::map<int64_t, size_t>& seen) {
  int64_t index = kMembers.optInteger(camera, "index", at + ".camera").value_or(static_cast<int64_t>(s));
  auto [it, added] = seen.emplace(index, s);
  if (!added) {
    bad(at + ".camera.index", std::to_string(index) + " is already the camera of samples[" +
                                  std::to_string(it->second) + "] of this run: a run holds one sample per camera");
  }
  return index;
}

// AVG over a column's non-null values as both engines take it: one plain
// sum in the order the values come, divided by their count (PostgreSQL's
// float8_accum and float8_avg; SQLite's sumStep and avgFinalize). A sum of
// finite values that leaves the doubles is refused, as PostgreSQL refused it.
class Mean {
 public:
  Mean(const char* column, const std::string& path) : column_(column), path_(path) {}
  void add(const std::optional<double>& value) {
    if (!value) return;
    double next = sum_ + *value;
    if (std::isinf(next) && !std::isinf(sum_) && !std::isinf(*value))
      bad(path_ + ".samples", std::string("the sum of the samples' ") + column_ + " is beyond the largest double");
    sum_ = next;
    ++count_;
  }
  std::optional<double> value() const {
    return count_ ? std::optional(sum_ / static_cast<double>(count_)) : std::nullopt;
  }

 private:
  const char* column_;
  const std::string& path_;
  double sum_ = 0;
  int64_t count_ = 0;
};

}  // namespace

std::vector<SampleValues> readSampleValues(const json& run, const std::string& path) {
  const json& samples = kMembers.array(run, "samples", path);
  std::vector<SampleValues> out;
  out.reserve(samples.size());
  std::map<int64_t, size_t> cameras;  // camera index -> the sample that has it
  for (size_t s = 0; s < samples.size(); ++s) {
    std::string at = path + ".samples[" + std::to_string(s) + "]";
    const json& sample = samples[s];
    if (!sample.is_object()) bad(at, "must be an object");
    const json* camera = find(sample, "camera");
    if (!camera || !camera->is_object()) bad(at + ".camera", "missing or not an object");
    SampleValues& v = out.emplace_back();
    v.cameraIndex = cameraIndexOf(*camera, s, at, cameras);
    v.times.frameMs = kMembers.number(sample, "frame_ms", at);
    // As the readers get them back (queries.cpp, frameTimes): an empty array is none.
    if (const json* frames = optFrameTimes(sample, "frame_ms_frames", at)) {
      v.times.frames.reserve(frames->size());
      for (const auto& ms : *frames) v.times.frames.push_back(ms.get<double>());
    }
    v.frameMsInstrumented = kMembers.optNumber(sample, "frame_ms_instrumented", at);
    v.overheadRatio = kMembers.optNumber(sample, "overhead_ratio", at);
    v.image = imageErrorColumns(sample, "image_error", at, "forward");
    v.sums = counterSums(sample, at);
  }
  return out;
}

RunSummaryColumns summarizeRun(std::span<const SampleValues> samples, const std::string& path) {
  // The walk of 0013's statement: the run's samples by its (run_id,
  // camera_index) index, so every sum adds in camera order.
  std::vector<size_t> order(samples.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return samples[a].cameraIndex < samples[b].cameraIndex; });
  Mean frame("frame_ms", path), bytes("bytes", path), instrumented("frame_ms_instrumented", path),
      overhead("overhead_ratio", path), psnr("image_error.psnr", path), footprint("footprint bytes", path),
      requested("footprint's requested bytes", path);
  RunSummaryColumns out;
  out.sampleCount = static_cast<int64_t>(samples.size());
  for (size_t s : order) {
    const SampleValues& v = samples[s];
    frame.add(v.times.frameMs);
    bytes.add(v.sums.bytes);
    instrumented.add(v.frameMsInstrumented);
    overhead.add(v.overheadRatio);
    out.imageCompared += v.image.against ? 1 : 0;
    out.imageIdentical += v.image.identical == 1 ? 1 : 0;
    psnr.add(v.image.psnr);
    // MIN as PostgreSQL's float8smaller keeps it: the new value unless the
    // kept one is smaller.
    if (v.image.psnr) out.minPsnr = out.minPsnr && *out.minPsnr < *v.image.psnr ? *out.minPsnr : *v.image.psnr;
    footprint.add(v.sums.footprint);
    requested.add(v.sums.footprintRequested);
  }
  out.meanFrameMs = frame.value();
  out.meanBytes = bytes.value();
  out.meanFrameMsInstrumented = instrumented.value();
  out.meanOverheadRatio = overhead.value();
  out.meanPsnr = psnr.value();
  out.meanFootprintBytes = footprint.value();
  out.meanFootprintRequestedBytes = requested.value();
  return out;
}

}  // namespace tally::store::detail

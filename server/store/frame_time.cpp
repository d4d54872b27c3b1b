#include "store/frame_time.hpp"

#include "common/median.hpp"

namespace tally::store {

RunFrameTime medianOfFrames(std::vector<double> times) {
  RunFrameTime out;
  const MedianInterval m = medianInterval(std::move(times));
  if (!m.median) return out;
  out.median = m.median;
  out.lower = m.lower;
  out.upper = m.upper;
  out.frames = m.n;
  out.source = "frames";
  return out;
}

RunFrameTime runFrameTime(const std::vector<SampleFrameTimes>& samples) {
  std::vector<double> times, medians;
  bool everyFrame = !samples.empty();
  for (const auto& s : samples) {
    medians.push_back(s.frameMs);
    everyFrame = everyFrame && !s.frames.empty();
    times.insert(times.end(), s.frames.begin(), s.frames.end());
  }
  if (everyFrame) return medianOfFrames(std::move(times));
  RunFrameTime out;
  if (medians.empty()) return out;
  // A sample without its frames: the median of the samples' medians, the
  // nearest statistic to the pooled median, without an interval.
  out = medianOfFrames(std::move(medians));
  out.lower = out.upper = std::nullopt;
  out.frames = 0;
  out.source = "samples";
  return out;
}

}  // namespace tally::store

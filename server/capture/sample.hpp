// One sample's measurements: the counted frames' lines (pass x resource x
// access x source) and the timed frames' pass times, gathered frame by frame
// and turned into the sample's JSON (docs/result-schema.md, "Result").
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderers/renderer.hpp"

namespace tally::capture {

// Accumulates one (pass, resource, direction) over frames.
struct Line {
  std::string pass, resource, source;
  std::string kind;  // Access::kind of its first frame ("": the resource's kind)
  bool write = false;
  bool onChip = false;  // Access::onChip (the tile-memory model)
  std::vector<double> counts, bytes;
  // Access::footprintBytes of the frames that measured it (>= 0); empty
  // where no frame did (footprint off, or a line the model cannot see).
  std::vector<double> footprint;
  std::vector<double> footprintBlocks;  // Access::footprintBlocks of the same frames
  uint32_t footprintClampedFrames = 0;  // frames whose Access::footprintClamped was set
};

// Accumulates one access site's share of one line over frames (RendererOptions::sites).
struct SiteLine {
  renderers::SiteCount site;  // its first frame's (what it is; count and bytes unused)
  std::string lineKey;        // its line's key in SampleMeasure::lines
  double count = 0, bytes = 0;  // summed over the frames
};

// Accumulates one draw's, the rest's or one material's share of a pass over
// frames (RendererOptions::draws).
struct DrawLine {
  renderers::DrawCount draw;  // what it is (its first frame's; counts unused)
  uint32_t draws = 0;         // draws it sums (the rest, a material), as last counted
  double count = 0, bytesRead = 0, bytesWritten = 0;  // summed over the frames
};

// A sample keeps a pass's kMaxDraws draws with the most bytes; the others
// are summed into its "draws_rest" (storage per sample stays bounded).
constexpr size_t kMaxDraws = 256;

// F instrumented frames: counts per frame; F uninstrumented frames: times.
struct SampleMeasure {
  std::vector<std::string> passOrder;
  std::map<std::pair<std::string, std::string>, Line> lines;  // key: pass + "\x1f" + resource + direction
  std::map<std::string, std::vector<double>> fragmentInvocations, statistic, instrumentedMs, plainMs;
  // Passes that dispatch compute work only.
  std::map<std::string, std::vector<double>> computeInvocations, computeStatistic;
  std::vector<double> frameMs, instrumentedFrameMs;
  // Each frame's host wall time (FrameResult::submitSeconds, in ms):
  // recording, submitting and waiting for the GPU, as a user's frame loop
  // sees it; uninstrumented and counted frames.
  std::vector<double> wallMs, instrumentedWallMs;
  // Each pass's time in every uninstrumented frame, in frame order and
  // aligned with frameMs (0 in a frame the pass did not run in).
  std::map<std::string, std::vector<double>> plainMsByFrame;
  std::map<std::string, std::vector<double>> arithmeticOps;  // per pass, where known (PassResult::arithmeticOps)
  std::set<std::string> arithmeticCounted;                    // passes whose arithmetic was counted, not estimated
  // Per pass, its sites in first-seen order (key: shader, instruction, line).
  std::map<std::string, std::vector<SiteLine>> sites;
  std::map<std::string, std::map<std::string, size_t>> siteIndex;
  // Per pass: its draws by scene draw index, the draws beyond the renderer's
  // cap, its materials by name, and the frames that counted them.
  std::map<std::string, std::map<uint32_t, DrawLine>> draws;
  std::map<std::string, DrawLine> drawsRest;
  std::map<std::string, std::map<std::string, DrawLine>> materials;
  std::map<std::string, uint32_t> drawFrames;
};

// A counted frame: its lines' counts, bytes and footprints, its pass times.
void addCounts(SampleMeasure& m, const renderers::FrameResult& frame);
// An uninstrumented frame: its pass times.
void addTimes(SampleMeasure& m, const renderers::FrameResult& frame);
// The frames' wall times beside their GPU times, into the sample's extras:
// "frame_wall_ms" (median of the uninstrumented frames) and
// "frame_wall_ms_instrumented" (median of the counted frames).
void addFrameWall(const SampleMeasure& m, nlohmann::json& extras);

// The sample's JSON (frames, times, passes with their lines), without the
// camera, images and extras the runner adds. Each line has "bytes" (the
// requested bytes: count x element size) and, where the counted frames
// measured it, "footprint_bytes" (the distinct bytes touched, mean over the
// frames that measured it) and "reuse" (bytes / footprint_bytes; null for a
// footprint of 0). Passes and the sample sum "footprint_bytes" over their
// lines that have one (absent where none has). "frame_ms_frames" (the sample)
// and "gpu_ms_frames" (each pass) hold every uninstrumented frame's time in
// order: their medians are frame_ms and gpu_ms.
// A pass's "sites": each site's count and bytes per frame (its sums over
// the frames divided by the frames its line was counted in, as the line's
// own mean is), sorted by bytes, most first.
nlohmann::json sitesJson(const SampleMeasure& m, const std::string& pass);

// A pass's "draws" (the kMaxDraws with the most bytes, most first),
// "draws_rest" (the others and the renderer's rest summed; null when none)
// and "materials" (most bytes first), per frame: sums over the frames that
// counted the pass's draws divided by their number.
nlohmann::json drawsJson(const SampleMeasure& m, const std::string& pass);
nlohmann::json drawsRestJson(const SampleMeasure& m, const std::string& pass);
nlohmann::json materialsJson(const SampleMeasure& m, const std::string& pass);

nlohmann::json sampleJson(const SampleMeasure& m, const std::vector<renderers::ResourceInfo>& resources,
                          uint32_t frames, uint32_t countedFrames);

}  // namespace tally::capture

// storeCapture: one capture result (docs/result-schema.md) -> rows, inside
// the caller's transaction. The runs are read and checked first (their
// scenes looked up; their samples' values read once, for the run's frame
// time and summary and for the samples' rows) and written; then each table
// in the foreign keys' order (resources, screenshots, samples, passes) is
// read in its own walk of
// the result and sent in pieces (batch_insert.hpp), which PostgreSQL stores
// while the next piece is read. Ids that children refer to (runs,
// screenshots, samples, passes) are reserved up front, so no row waits for
// its parent's id. Bad input throws IngestError naming the JSON path, and
// the caller's transaction rolls back whatever was written.
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <optional>
#include <set>
#include <stdexcept>
#include <string_view>
#include <tuple>
#include <vector>

#include "common/json_fields.hpp"
#include "store/batch_insert.hpp"
#include "store/count_spread.hpp"
#include "store/ingest_input.hpp"
#include "store/ingest_sites.hpp"
#include "store/internal.hpp"
#include "store/piece_pipe.hpp"

namespace tally::store::detail {

using nlohmann::json;
using json_fields::find;

namespace {

// Ids handed out in order from a reserved list.
class Ids {
 public:
  explicit Ids(std::vector<int64_t> ids) : ids_(std::move(ids)) {}
  int64_t next() {
    // The count came from the same result, so this holds unless the counting below is wrong.
    if (at_ == ids_.size()) throw IngestError("more rows than ids reserved for them");
    return ids_[at_++];
  }

 private:
  std::vector<int64_t> ids_;
  size_t at_ = 0;
};

// How many rows of each table with children a result makes; shapes that the
// reading below refuses count as nothing.
struct RowCounts {
  size_t runs = 0, screenshots = 0, samples = 0, passes = 0;
};

RowCounts countRows(const json& runs) {
  RowCounts n;
  for (const auto& run : runs) {
    ++n.runs;
    const json* samples = run.is_object() ? find(run, "samples") : nullptr;
    if (!samples || !samples->is_array()) continue;
    for (const auto& sample : *samples) {
      if (!sample.is_object()) continue;
      ++n.samples;
      if (find(sample, "screenshot")) ++n.screenshots;
      const json* passes = find(sample, "passes");
      if (passes && passes->is_array()) n.passes += passes->size();
    }
  }
  return n;
}

// The passes' columns; on PostgreSQL the counters' arrays (kCounterArrays,
// in the order addCounters writes them) end the row.
std::vector<std::string> passColumns(bool counterArrays) {
  std::vector<std::string> columns = {"id", "sample_id", "position", "name", "gpu_ms", "gpu_ms_spread",
                                      "gpu_ms_instrumented", "overhead_ratio", "fragment_invocations",
                                      "fragment_invocations_statistic", "compute_invocations",
                                      "compute_invocations_statistic", "gpu_ms_frames"};
  if (counterArrays) {
    for (const CounterArray& a : kCounterArrays) columns.emplace_back(a.array);
  }
  return columns;
}

// Every row of one capture, by table, and the ids reserved for them,
// written in the foreign keys' order (storeCapture).
struct CaptureRows {
  CaptureRows(Connection* connection, const RowCounts& counts)
      : db(connection),
        reserved(reserveIds(db, std::array<std::pair<std::string_view, size_t>, 4>{{{"runs", counts.runs},
                                                                                   {"screenshots", counts.screenshots},
                                                                                   {"samples", counts.samples},
                                                                                   {"passes", counts.passes}}})),
        runIds(std::move(reserved[0])),
        screenshotIds(std::move(reserved[1])),
        sampleIds(std::move(reserved[2])),
        passIds(std::move(reserved[3])),
        runs(db, "runs",
             {"id", "job_id", "device_id", "renderer", "scene_id", "width", "height", "counting", "lights",
              "render_target_bytes", "notes", "shaders", "counter_headroom", "options", "variant", "tally_version",
              "tally_commit", "footprint_block_bytes", "host", "frame_time_median", "frame_time_lower",
              "frame_time_upper", "frame_time_frames", "frame_time_source", "sample_count", "mean_frame_ms",
              "mean_bytes", "mean_frame_ms_instrumented", "mean_overhead_ratio", "image_compared",
              "image_identical", "mean_psnr", "min_psnr", "mean_footprint_bytes",
              "mean_footprint_requested_bytes"}),
        resources(db, "run_resources",
                  {"run_id", "position", "name", "kind", "format", "element_bytes", "width", "height",
                   "allocation_bytes", "format_bytes", "usage"}),
        screenshots(db, "screenshots", {"id", "name", "png", "width", "height"}),
        samples(db, "samples",
                {"id", "run_id", "camera_index", "camera", "sky_fraction", "sky_fraction_estimate", "frames",
                 "frame_ms", "frame_ms_spread", "frame_ms_instrumented", "overhead_ratio", "image_against",
                 "image_identical", "psnr", "max_abs", "mean_abs", "screenshot_id", "extras", "variant_against",
                 "variant_identical", "variant_psnr", "variant_max_abs", "variant_mean_abs", "frame_ms_frames",
                 "bytes", "footprint_bytes", "footprint_requested_bytes"}),
        counterArrays(db->engine() == Engine::Postgres),
        passes(db, "passes", passColumns(counterArrays),
               counterArrays ? BatchInsert::Format::kBinary : BatchInsert::Format::kText),
        counters(db, "counters",
                 {"pass_id", "position", "resource", "kind", "format", "access", "count", "bytes", "count_spread",
                  "source", "footprint_bytes"}),
        findScene(db, "SELECT id FROM scenes WHERE name = ?1 AND params = ?2"),
        insertScene(db,
                    "INSERT INTO scenes (name, params) VALUES (?1, ?2) "
                    "ON CONFLICT (name, params) DO UPDATE SET name = excluded.name RETURNING id") {}

  void startPasses();
  void writePasses();
  // Reads every sample's passes into rows, calling `piece` after each
  // kPassesPerPiece of them and once at the end; stops when it returns false.
  template <class Piece>
  void readPasses(Piece piece);

  Connection* db;
  // Sites, draws and materials of each pass, and each run's shader sources
  // (store/ingest_sites.hpp): written after the rows they refer to, in the
  // same transaction.
  std::vector<std::tuple<int64_t, const json*, std::string>> passSites, runShaders;
  std::vector<std::vector<int64_t>> reserved;  // handed to the Ids below
  Ids runIds, screenshotIds, sampleIds, passIds;
  BatchInsert runs, resources, screenshots, samples;
  // PostgreSQL: a pass's counters are arrays on its row (migration 0012), and
  // `counters` (no rows written) is the view over them; SQLite: rows of counters.
  bool counterArrays;
  BatchInsert passes, counters;
  Statement findScene, insertScene;
  std::map<std::pair<std::string, std::string>, int64_t> sceneIds;  // by name and compact params
  json ceilings;  // the capture's device.ceilings (null when not measured)
  // Each sample's id (taken with its run's row, addRun), object and path,
  // in the samples' order: for its row (addSamples) and its passes' rows
  // (startPasses, writePasses).
  std::vector<std::tuple<int64_t, const json*, std::string>> samplesPasses;
  // Each sample's screenshot id, in the samples' order (addScreenshots),
  // for its row (addSamples).
  std::vector<std::optional<int64_t>> sampleScreenshots;
  // Each sample's values that its run's row summarises, read with the run
  // (addRun), in the samples' order, for its row (addSamples).
  std::vector<SampleValues> sampleValues;
  // PostgreSQL: the passes' rows, read and formatted on a thread of their
  // own (startPasses) while the tables before them are written. Last, so
  // that it is destroyed (the thread stopped and joined) before the members
  // that thread uses.
  std::optional<PiecePipe> passPieces;
};

// The member, not copied (null when absent), for BatchInsert::add(const json*).
const json* optJson(const json& object, const char* key) { return find(object, key); }

// The pass's counters: rows of counters, or (in.counterArrays) the arrays
// that end the pass's row, which addPasses has begun.
void addCounters(CaptureRows& in, int64_t passId, const json& pass, const std::string& path) {
  const json& counters = kMembers.array(pass, "resources", path);
  using Of = BinaryArray::Of;
  BinaryArray resources(Of::kText), kinds(Of::kText), formats(Of::kText), accesses(Of::kText),
      counts(Of::kFloat8), bytesArray(Of::kFloat8), spreads(Of::kText), sources(Of::kText),
      footprints(Of::kFloat8);
  for (size_t c = 0; c < counters.size(); ++c) {
    auto [resource, access, source, kind, format, count, bytes, footprint, spread] =
        counterFields(counters[c], path, c);
    // n alone where every frame counted the same (store/count_spread.hpp).
    std::optional<json> frames;
    if (auto n = spread ? constantSpreadFrames(*spread, count) : std::nullopt) {
      frames = *n;
      spread = &*frames;
    }
    if (in.counterArrays) {
      resources.add(resource);
      kinds.add(kind);
      formats.add(format);
      accesses.add(access);
      counts.add(count);
      bytesArray.add(bytes);
      spreads.add(spread);
      sources.add(source);
      footprints.add(footprint);
    } else {
      in.counters.row()
          .add(passId)
          .add(static_cast<int64_t>(c))
          .add(resource)
          .add(kind)
          .add(format)
          .add(access)
          .add(count)
          .add(bytes)
          .add(spread)
          .add(source)
          .add(footprint);
    }
  }
  if (in.counterArrays) {
    for (BinaryArray* array :
         {&resources, &kinds, &formats, &accesses, &counts, &bytesArray, &spreads, &sources, &footprints}) {
      in.passes.add(*array);
    }
  }
}

// The sample's passes; how many.
size_t addPasses(CaptureRows& in, int64_t sampleId, const json& sample, const std::string& path) {
  const json& passes = kMembers.array(sample, "passes", path);
  for (size_t p = 0; p < passes.size(); ++p) {
    std::string at = path + ".passes[" + std::to_string(p) + "]";
    const json& pass = passes[p];
    if (!pass.is_object()) bad(at, "must be an object");
    int64_t passId = in.passIds.next();
    in.passes.row()
        .add(passId)
        .add(sampleId)
        .add(static_cast<int64_t>(p))
        .add(kMembers.text(pass, "name", at))
        .add(kMembers.number(pass, "gpu_ms", at))
        .add(optJson(pass, "gpu_ms_spread"))
        .add(kMembers.optNumber(pass, "gpu_ms_instrumented", at))
        .add(kMembers.optNumber(pass, "overhead_ratio", at))
        .add(kMembers.optNumber(pass, "fragment_invocations", at))
        .add(kMembers.optNumber(pass, "fragment_invocations_statistic", at))
        .add(kMembers.optNumber(pass, "compute_invocations", at))
        .add(kMembers.optNumber(pass, "compute_invocations_statistic", at))
        .add(optFrameTimes(pass, "gpu_ms_frames", at));
    addCounters(in, passId, pass, at);
    in.passSites.emplace_back(passId, &pass, at);
  }
  return passes.size();
}

constexpr size_t kPassesPerPiece = 64;

template <class Piece>
void CaptureRows::readPasses(Piece piece) {
  size_t held = 0;
  for (const auto& [sampleId, sample, path] : samplesPasses) {
    held += addPasses(*this, sampleId, *sample, path);
    if (held < kPassesPerPiece) continue;
    if (!piece()) return;
    held = 0;
  }
  piece();
}

// PostgreSQL: the passes of every sample are read into rows and formatted
// for their COPY on a thread of their own, from when every sample has its
// id (after the runs' rows) while this thread writes the resources,
// screenshots and samples; writePasses then only sends them. Most of a
// capture's rows are its passes, and the server stores a piece while the
// next is read (docs/benchmarks.md, "Ingest on PostgreSQL at 5,000
// samples/s"). That thread uses the passes' rows, ids and sites alone, and
// reads the result and samplesPasses, which nothing changes meanwhile.
void CaptureRows::startPasses() {
  if (!counterArrays) return;  // SQLite: writePasses reads them on this thread
  // push() is false once the ingest gave up.
  passPieces.emplace([this](PiecePipe& out) { readPasses([&] { return out.push(passes.take()); }); });
}

// The passes of every sample, after the samples' rows they refer to: on
// PostgreSQL the pieces startPasses formatted, into one COPY as they come
// (its errors, bad input among them, rethrown here); on SQLite read and
// inserted in pieces.
void CaptureRows::writePasses() {
  if (passPieces) {
    CopyStream stream(db, passes.copyStatement(), passes.format() == BatchInsert::Format::kBinary);
    while (auto piece = passPieces->pop()) {
      if (!piece->empty()) stream.send(*piece);
    }
    passPieces.reset();  // joined: its passes' sites are whole
    stream.finish();
    return;
  }
  readPasses([&] {
    passes.send();
    return true;
  });
  passes.flush();
  counters.flush();
}

std::optional<int64_t> addScreenshot(CaptureRows& in, const json& sample, const std::string& path,
                                     const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  auto name = kMembers.optText(sample, "screenshot", path);
  if (!name) return std::nullopt;
  auto it = screenshots.find(*name);
  if (it == screenshots.end())
    bad(path + ".screenshot", "'" + *name + "' is not among the screenshots given");
  auto [width, height] = pngSize(it->second, path + ".screenshot");
  int64_t id = in.screenshotIds.next();
  in.screenshots.row().add(id).add(*name).add(std::span<const uint8_t>(it->second)).add(width).add(height);
  return id;
}

BatchInsert& addImageError(BatchInsert& row, const ImageErrorColumns& e) {
  return row.add(e.against).add(e.identical).add(e.psnr).add(e.maxAbs).add(e.meanAbs);
}

// The screenshots of the run's samples (before the samples' rows, which
// refer to them).
void addScreenshots(CaptureRows& in, const json& run, const std::string& path,
                    const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  const json& samples = kMembers.array(run, "samples", path);
  for (size_t s = 0; s < samples.size(); ++s) {
    in.sampleScreenshots.push_back(
        addScreenshot(in, samples[s], path + ".samples[" + std::to_string(s) + "]", screenshots));
  }
}

// Adds the run's samples' rows, sending them in pieces; `sampleAt`: the
// first of the run's samples in CaptureRows::sampleScreenshots, sampleValues
// and samplesPasses (read with the run, addRun).
void addSamples(CaptureRows& in, int64_t runId, const json& run, const std::string& path, size_t& sampleAt) {
  constexpr size_t kSamplesPerPiece = 64;
  const json& samples = kMembers.array(run, "samples", path);
  for (size_t s = 0; s < samples.size(); ++s, ++sampleAt) {
    std::string at = path + ".samples[" + std::to_string(s) + "]";
    const json& sample = samples[s];  // an object with a camera object: readSampleValues checked
    const SampleValues& values = in.sampleValues.at(sampleAt);
    // -1: the renderer has no skybox pass.
    std::optional<double> sky;
    if (find(sample, "sky_fraction")) {
      if (double given = kMembers.number(sample, "sky_fraction", at); given >= 0) sky = given;
    }
    // A variant's error against its reference variant; "against" is required
    // there, as no renderer is its implied reference.
    ImageErrorColumns variant = imageErrorColumns(sample, "variant_error", at, std::nullopt);
    std::optional<int64_t> screenshotId = in.sampleScreenshots.at(sampleAt);
    auto frames = kMembers.optInteger(sample, "frames", at);
    auto skyEstimate = kMembers.optNumber(sample, "sky_fraction_estimate", at);
    json extras = extrasWithRoofline(kMembers.object(sample, "extras", at), sample, in.ceilings);
    auto frameTimes = optFrameTimes(sample, "frame_ms_frames", at);
    int64_t sampleId = std::get<0>(in.samplesPasses.at(sampleAt));
    const CounterSums& sums = values.sums;
    in.samples.row()
        .add(sampleId)
        .add(runId)
        .add(values.cameraIndex)
        .add(*find(sample, "camera"))
        .add(sky)
        .add(skyEstimate)
        .add(frames)
        .add(values.times.frameMs)
        .add(optJson(sample, "frame_ms_spread"))
        .add(values.frameMsInstrumented)
        .add(values.overheadRatio);
    addImageError(in.samples, values.image).add(screenshotId).add(extras);
    addImageError(in.samples, variant)
        .add(frameTimes)
        .add(sums.bytes)
        .add(sums.footprint)
        .add(sums.footprintRequested);
    if (in.samples.rows() >= kSamplesPerPiece) in.samples.send();
  }
}

void addResources(CaptureRows& in, int64_t runId, const json& list, const std::string& path) {
  for (size_t r = 0; r < list.size(); ++r) {
    std::string at = path + "[" + std::to_string(r) + "]";
    const json& resource = list[r];
    if (!resource.is_object()) bad(at, "must be an object");
    in.resources.row()
        .add(runId)
        .add(static_cast<int64_t>(r))
        .add(kMembers.text(resource, "name", at))
        .add(kMembers.text(resource, "kind", at))
        .add(kMembers.optText(resource, "format", at))
        .add(kMembers.optInteger(resource, "element_bytes", at))
        .add(kMembers.optInteger(resource, "width", at))
        .add(kMembers.optInteger(resource, "height", at))
        .add(kMembers.optInteger(resource, "allocation_bytes", at))
        .add(kMembers.optInteger(resource, "format_bytes", at))
        .add(kMembers.optText(resource, "usage", at));
  }
}

// The build that made a result: {"version", "commit"} (absent before builds recorded it).
struct Build {
  std::optional<std::string> version, commit;
};

Build buildOf(const json& result) {
  const json* tally = find(result, "tally");
  if (!tally) return {};
  if (!tally->is_object()) bad("tally", "must be an object");
  return {kMembers.optText(*tally, "version", "tally"), kMembers.optText(*tally, "commit", "tally")};
}

// The scene's id: stored already (a plain read, so that concurrent ingests
// of one scene do not queue on the upsert's row lock), or inserted now.
int64_t sceneId(CaptureRows& in, const std::string& name, const json& params) {
  auto key = std::make_pair(name, params.dump());
  if (auto it = in.sceneIds.find(key); it != in.sceneIds.end()) return it->second;
  in.findScene.reset();
  in.findScene.bind(1, name).bind(2, params);
  int64_t id = 0;
  if (in.findScene.step()) {
    id = in.findScene.getInt(0);
    in.findScene.run();
  } else {
    in.insertScene.reset();
    in.insertScene.bind(1, name).bind(2, params);
    if (!in.insertScene.step()) throw IngestError("no id returned");
    id = in.insertScene.getInt(0);
    in.insertScene.run();
  }
  return in.sceneIds[key] = id;
}

struct RunContext {
  int64_t jobId = 0, deviceId = 0;
  json shaders;
  Build build;
  std::optional<std::string> host;
};

// The run's row; its id. Its resources and samples follow (storeCapture).
int64_t addRun(CaptureRows& in, const RunContext& context, const json& run, const std::string& path) {
  if (!run.is_object()) bad(path, "must be an object");
  int64_t scene = sceneId(in, kMembers.text(run, "scene", path), kMembers.object(run, "scene_params", path));
  int64_t width = kMembers.integer(run, "width", path);
  int64_t height = kMembers.integer(run, "height", path);
  if (width < 1 || width > 16384) bad(path + ".width", "must be between 1 and 16384");
  if (height < 1 || height > 16384) bad(path + ".height", "must be between 1 and 16384");
  int64_t lights = kMembers.optInteger(run, "lights", path).value_or(0);
  if (lights < 0) bad(path + ".lights", "must not be negative");
  json resources = kMembers.object(run, "resources", path);
  std::optional<json> headroom;  // absent in results from before it was measured
  if (const json* h = find(run, "counter_headroom")) {
    if (!h->is_object()) bad(path + ".counter_headroom", "must be an object");
    headroom = *h;
  }
  // The footprint's block size; absent or null when footprint was off.
  std::optional<int64_t> footprintBlock = kMembers.optInteger(run, "footprint_block_bytes", path);
  if (footprintBlock && *footprintBlock != 32 && *footprintBlock != 64 && *footprintBlock != 128)
    bad(path + ".footprint_block_bytes", "must be 32, 64 or 128, got " + std::to_string(*footprintBlock));
  std::string renderer = kMembers.text(run, "renderer", path);
  std::string counting = kMembers.optText(run, "counting", path).value_or("exact");
  std::optional<int64_t> renderTargetBytes = kMembers.optInteger(resources, "render_target_bytes", path + ".resources");
  json notes = kMembers.object(run, "notes", path);
  json options = kMembers.object(run, "options", path);
  std::string variant = kMembers.optText(run, "variant", path).value_or(renderer);
  kMembers.array(resources, "list", path + ".resources");  // checked here, read by addResources
  int64_t runId = in.runIds.next();
  in.runShaders.emplace_back(runId, &run, path);
  // The run's row carries its samples' frame time and summary (0013), from
  // their values read here once, and kept for their own rows (addSamples).
  std::vector<SampleValues> values = readSampleValues(run, path);
  std::vector<SampleFrameTimes> times;
  times.reserve(values.size());
  for (const SampleValues& v : values) times.push_back(v.times);
  RunFrameTime frameTime = runFrameTime(times);
  RunSummaryColumns summary = summarizeRun(values, path);
  const json& samples = kMembers.array(run, "samples", path);  // as readSampleValues read it
  for (size_t s = 0; s < samples.size(); ++s)
    in.samplesPasses.emplace_back(in.sampleIds.next(), &samples[s], path + ".samples[" + std::to_string(s) + "]");
  std::move(values.begin(), values.end(), std::back_inserter(in.sampleValues));
  in.runs.row()
      .add(runId)
      .add(context.jobId)
      .add(context.deviceId)
      .add(renderer)
      .add(scene)
      .add(width)
      .add(height)
      .add(std::move(counting))
      .add(lights)
      .add(renderTargetBytes)
      .add(notes)
      .add(context.shaders)
      .add(headroom)
      .add(options)
      .add(std::move(variant))
      .add(context.build.version)
      .add(context.build.commit)
      .add(footprintBlock)
      .add(context.host)
      .add(frameTime.median)
      .add(frameTime.lower)
      .add(frameTime.upper)
      .add(static_cast<int64_t>(frameTime.frames))
      .add(frameTime.source)
      .add(summary.sampleCount)
      .add(summary.meanFrameMs)
      .add(summary.meanBytes)
      .add(summary.meanFrameMsInstrumented)
      .add(summary.meanOverheadRatio)
      .add(summary.imageCompared)
      .add(summary.imageIdentical)
      .add(summary.meanPsnr)
      .add(summary.minPsnr)
      .add(summary.meanFootprintBytes)
      .add(summary.meanFootprintRequestedBytes);
  return runId;
}

}  // namespace

int64_t storeCapture(Connection* db, int64_t jobId, const json& result,
                     const std::map<std::string, std::vector<uint8_t>>& screenshots,
                     const std::optional<std::string>& host) {
  // Idempotency: a job's result replaces whatever was ingested for it before
  // (its screenshots first, then its runs, which cascade to samples,
  // passes, counters and resources).
  Statement dropShots(db,
                      "DELETE FROM screenshots WHERE id IN (SELECT s.screenshot_id FROM samples s "
                      "JOIN runs r ON r.id = s.run_id WHERE r.job_id = ?1)");
  dropShots.bind(1, jobId).run();
  Statement dropRuns(db, "DELETE FROM runs WHERE job_id = ?1");
  dropRuns.bind(1, jobId).run();

  RunContext context{jobId, insertDevice(db, result), {}, {}, host};
  json ceilings;
  if (const json* device = find(result, "device"); device && device->is_object()) {
    if (const json* c = find(*device, "ceilings"); c && c->is_object()) ceilings = *c;
  }
  context.shaders = kMembers.object(result, "shaders", "result");
  context.build = buildOf(result);
  const json* runs = find(result, "runs");
  if (!runs || !runs->is_array()) bad("runs", "missing or not an array");
  CaptureRows in(db, countRows(*runs));
  in.ceilings = std::move(ceilings);
  // The runs first: their scenes are looked up by statements, which cannot
  // run while a COPY is open. Then every other table in its own walk, in
  // the foreign keys' order, sent in pieces while the next is read.
  std::vector<std::tuple<int64_t, const json*, std::string>> stored;  // each run's id, object and path
  for (size_t r = 0; r < runs->size(); ++r) {
    std::string path = "runs[" + std::to_string(r) + "]";
    stored.emplace_back(addRun(in, context, (*runs)[r], path), &(*runs)[r], std::move(path));
  }
  in.startPasses();
  in.runs.flush();
  constexpr size_t kResourcesPerPiece = 512, kScreenshotsPerPiece = 16;
  for (const auto& [runId, run, path] : stored) {
    const json& list = kMembers.array(kMembers.object(*run, "resources", path), "list", path + ".resources");
    addResources(in, runId, list, path + ".resources.list");
    if (in.resources.rows() >= kResourcesPerPiece) in.resources.send();
  }
  in.resources.flush();
  for (const auto& [runId, run, path] : stored) {
    addScreenshots(in, *run, path, screenshots);
    if (in.screenshots.rows() >= kScreenshotsPerPiece) in.screenshots.send();
  }
  in.screenshots.flush();
  size_t sampleAt = 0;
  for (const auto& [runId, run, path] : stored) addSamples(in, runId, *run, path, sampleAt);
  in.samples.flush();
  in.writePasses();
  for (const auto& [runId, run, path] : in.runShaders) insertShaderSources(db, runId, *run, path);
  for (const auto& [passId, pass, path] : in.passSites) insertPassSites(db, passId, *pass, path);
  return static_cast<int64_t>(runs->size());
}

}  // namespace tally::store::detail

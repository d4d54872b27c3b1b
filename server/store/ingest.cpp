// ingestCapture: one capture result (docs/result-schema.md) -> rows, and
// ingestSweep: one sweep result -> a sweeps row; each in one write
// transaction. Bad input throws IngestError naming the JSON path; the
// transaction then rolls back, so nothing of the job is half-written.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "common/json_fields.hpp"
#include "store/ingest_input.hpp"
#include "store/ingest_sites.hpp"
#include "store/internal.hpp"

namespace tally::store {

using nlohmann::json;

namespace {

using detail::bad;
using detail::IngestError;
using detail::kMembers;
using json_fields::find;

// Width and height from a PNG's IHDR chunk (the signature and IHDR come first).
std::pair<int64_t, int64_t> pngSize(const std::vector<uint8_t>& png, const std::string& path) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (png.size() < 24 || !std::equal(kSignature, kSignature + 8, png.begin()) || png[12] != 'I' ||
      png[13] != 'H' || png[14] != 'D' || png[15] != 'R') {
    bad(path, "not a PNG image");
  }
  auto be32 = [&](size_t at) {
    return int64_t{png[at]} << 24 | int64_t{png[at + 1]} << 16 | int64_t{png[at + 2]} << 8 |
           int64_t{png[at + 3]};
  };
  return {be32(16), be32(20)};
}

// The prepared statements of one ingest, reused across rows.
struct Inserter {
  explicit Inserter(Connection* connection)
      : db(connection),
        device(db,
               "INSERT INTO devices (fingerprint, name, vendor, driver, api_version, features, info) "
               "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7) ON CONFLICT (fingerprint) DO UPDATE SET info = "
               "excluded.info "
               "RETURNING id"),
        scene(db,
              "INSERT INTO scenes (name, params) VALUES (?1, ?2) "
              "ON CONFLICT (name, params) DO UPDATE SET name = excluded.name RETURNING id"),
        run(db,
            "INSERT INTO runs (job_id, device_id, renderer, scene_id, width, height, counting, lights, "
            "render_target_bytes, notes, shaders, counter_headroom, options, variant, tally_version, tally_commit, "
            "footprint_block_bytes) "
            "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17) RETURNING id"),
        resource(
            db,
            "INSERT INTO run_resources (run_id, position, name, kind, format, element_bytes, width, height, "
            "allocation_bytes, format_bytes, usage) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)"),
        screenshot(db, "INSERT INTO screenshots (name, png, width, height) VALUES (?1, ?2, ?3, ?4) RETURNING id"),
        sample(
            db,
            "INSERT INTO samples (run_id, camera_index, camera, sky_fraction, sky_fraction_estimate, frames, "
            "frame_ms, frame_ms_spread, frame_ms_instrumented, overhead_ratio, image_against, "
            "image_identical, "
            "psnr, max_abs, mean_abs, screenshot_id, extras, variant_against, variant_identical, variant_psnr, "
            "variant_max_abs, variant_mean_abs, frame_ms_frames) "
            "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20, "
            "?21, ?22, ?23) RETURNING id"),
        pass(db,
             "INSERT INTO passes (sample_id, position, name, gpu_ms, gpu_ms_spread, gpu_ms_instrumented, "
             "overhead_ratio, fragment_invocations, fragment_invocations_statistic, compute_invocations, "
             "compute_invocations_statistic, gpu_ms_frames) "
             "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12) RETURNING id"),
        counter(db,
                "INSERT INTO counters (pass_id, position, resource, kind, format, access, count, bytes, "
                "count_spread, source, footprint_bytes) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)"),
        sampleBytes(db,
                    "UPDATE samples SET bytes = ?2, footprint_bytes = ?3, footprint_requested_bytes = ?4 "
                    "WHERE id = ?1"),
        // Most ingests find their device and scene stored: a plain read then,
        // so that concurrent ingests (a fleet of one GPU model capturing one
        // scene) do not queue on the upsert's row lock.
        findDevice(db, "SELECT id FROM devices WHERE fingerprint = ?1 AND info = ?2"),
        findScene(db, "SELECT id FROM scenes WHERE name = ?1 AND params = ?2") {}
  Connection* db;
  Statement device, scene, run, resource, screenshot, sample, pass, counter, sampleBytes, findDevice, findScene;
  nlohmann::json ceilings;  // the capture's device.ceilings (null when not measured)
  // The sample being inserted: all its lines' bytes; the footprint of the
  // lines that have one and those lines' requested bytes (null when none has).
  struct Sums {
    double bytes = 0;
    std::optional<double> footprint, footprintRequested;
  } sums;
};

int64_t returnedId(Statement& statement) {
  if (!statement.step()) throw IngestError("no id returned");
  int64_t id = statement.getInt(0);
  statement.run();
  return id;
}

int64_t insertDevice(Inserter& in, const json& result) {
  const json* device = find(result, "device");
  if (!device || !device->is_object()) bad("device", "missing or not an object");
  std::string name = kMembers.text(*device, "name", "device");
  std::string vendor = kMembers.optText(*device, "vendorID", "device").value_or("");
  std::string deviceId = kMembers.optText(*device, "deviceID", "device").value_or("");
  std::string driver = kMembers.optText(*device, "driverInfo", "device").value_or("");
  std::string api = kMembers.optText(*device, "apiVersion", "device").value_or("");
  // Unit separators keep the fields apart whatever they contain.
  std::string fingerprint = name + '\x1f' + vendor + '\x1f' + deviceId + '\x1f' + driver + '\x1f' + api;
  in.findDevice.reset();
  in.findDevice.bind(1, fingerprint).bind(2, *device);
  if (in.findDevice.step()) {
    int64_t id = in.findDevice.getInt(0);
    in.findDevice.run();
    return id;
  }
  in.device.reset();
  in.device.bind(1, fingerprint)
      .bind(2, name)
      .bind(3, vendor)
      .bind(4, driver)
      .bind(5, api)
      .bind(6, kMembers.object(*device, "features", "device"))
      .bind(7, *device);
  return returnedId(in.device);
}

std::optional<json> optJson(const json& object, const char* key) {
  const json* value = find(object, key);
  return value ? std::optional<json>(*value) : std::nullopt;
}

// Per-frame times (frame_ms_frames, gpu_ms_frames): absent (or null), or an
// array of finite, non-negative milliseconds; errors name the entry.
std::optional<json> optFrameTimes(const json& object, const char* key, const std::string& path) {
  const json* value = find(object, key);
  if (!value) return std::nullopt;
  std::string at = path + "." + key;
  if (!value->is_array()) bad(at, "must be an array of milliseconds, got " + value->dump());
  for (size_t i = 0; i < value->size(); ++i) {
    const json& ms = (*value)[i];
    std::string entry = at + "[" + std::to_string(i) + "]";
    if (!ms.is_number()) bad(entry, "must be a number, got " + ms.dump());
    double x = ms.get<double>();
    if (!std::isfinite(x)) bad(entry, "must be finite");
    if (x < 0) bad(entry, "must not be negative, got " + ms.dump());
  }
  return *value;
}

void insertCounters(Inserter& in, int64_t passId, const json& pass, const std::string& path) {
  const json& counters = kMembers.array(pass, "resources", path);
  for (size_t c = 0; c < counters.size(); ++c) {
    std::string at = path + ".resources[" + std::to_string(c) + "]";
    const json& counter = counters[c];
    if (!counter.is_object()) bad(at, "must be an object");
    std::string access = kMembers.text(counter, "access", at);
    if (access != "read" && access != "write")
      bad(at + ".access", "must be \"read\" or \"write\", got \"" + access + "\"");
    // Absent (or null) where the line's footprint was not measured.
    std::optional<double> footprint = kMembers.optNumber(counter, "footprint_bytes", at);
    if (footprint && *footprint < 0) bad(at + ".footprint_bytes", "must not be negative");
    in.counter.reset();
    in.counter.bind(1, passId)
        .bind(2, static_cast<int64_t>(c))
        .bind(3, kMembers.text(counter, "name", at))
        .bind(4, kMembers.optText(counter, "kind", at))
        .bind(5, kMembers.optText(counter, "format", at))
        .bind(6, access)
        .bind(7, kMembers.number(counter, "count", at))
        .bind(8, kMembers.number(counter, "bytes", at))
        .bind(9, optJson(counter, "count_spread"))
        .bind(10, kMembers.text(counter, "source", at))
        .bind(11, footprint);
    in.counter.run();
    double bytes = kMembers.number(counter, "bytes", at);
    in.sums.bytes += bytes;
    if (footprint) {
      in.sums.footprint = in.sums.footprint.value_or(0) + *footprint;
      in.sums.footprintRequested = in.sums.footprintRequested.value_or(0) + bytes;
    }
  }
}

void insertPasses(Inserter& in, int64_t sampleId, const json& sample, const std::string& path) {
  const json& passes = kMembers.array(sample, "passes", path);
  for (size_t p = 0; p < passes.size(); ++p) {
    std::string at = path + ".passes[" + std::to_string(p) + "]";
    const json& pass = passes[p];
    if (!pass.is_object()) bad(at, "must be an object");
    in.pass.reset();
    in.pass.bind(1, sampleId)
        .bind(2, static_cast<int64_t>(p))
        .bind(3, kMembers.text(pass, "name", at))
        .bind(4, kMembers.number(pass, "gpu_ms", at))
        .bind(5, optJson(pass, "gpu_ms_spread"))
        .bind(6, kMembers.optNumber(pass, "gpu_ms_instrumented", at))
        .bind(7, kMembers.optNumber(pass, "overhead_ratio", at))
        .bind(8, kMembers.optNumber(pass, "fragment_invocations", at))
        .bind(9, kMembers.optNumber(pass, "fragment_invocations_statistic", at))
        .bind(10, kMembers.optNumber(pass, "compute_invocations", at))
        .bind(11, kMembers.optNumber(pass, "compute_invocations_statistic", at))
        .bind(12, optFrameTimes(pass, "gpu_ms_frames", at));
    int64_t passId = returnedId(in.pass);
    insertCounters(in, passId, pass, at);
    detail::insertPassSites(in.db, passId, pass, at);
  }
}

std::optional<int64_t> insertScreenshot(Inserter& in, const json& sample, const std::string& path,
                                        const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  auto name = kMembers.optText(sample, "screenshot", path);
  if (!name) return std::nullopt;
  auto it = screenshots.find(*name);
  if (it == screenshots.end())
    bad(path + ".screenshot", "'" + *name + "' is not among the screenshots given");
  auto [width, height] = pngSize(it->second, path + ".screenshot");
  in.screenshot.reset();
  in.screenshot.bind(1, *name).bind(2, std::span<const uint8_t>(it->second)).bind(3, width).bind(4, height);
  return returnedId(in.screenshot);
}

// The columns of an {"against", "psnr", "identical", "max_abs", "mean_abs"}
// object; all empty when the sample has no such key.
struct ImageErrorColumns {
  std::optional<std::string> against;
  std::optional<int64_t> identical;
  std::optional<double> psnr, maxAbs, meanAbs;
};

ImageErrorColumns imageErrorColumns(const json& sample, const char* key, const std::string& at,
                                    const std::optional<std::string>& defaultAgainst) {
  ImageErrorColumns out;
  const json* error = find(sample, key);
  if (!error) return out;
  std::string errorPath = at + "." + key;
  if (!error->is_object()) bad(errorPath, "must be an object");
  out.against = defaultAgainst ? kMembers.optText(*error, "against", errorPath).value_or(*defaultAgainst)
                               : kMembers.text(*error, "against", errorPath);
  const json* same = find(*error, "identical");
  if (same && !same->is_boolean()) bad(errorPath + ".identical", "must be true or false");
  out.psnr = kMembers.optNumber(*error, "psnr", errorPath);
  out.identical = same ? int64_t{same->get<bool>()} : int64_t{!out.psnr};
  out.maxAbs = kMembers.number(*error, "max_abs", errorPath);
  out.meanAbs = kMembers.number(*error, "mean_abs", errorPath);
  return out;
}

// The sample's extras, with "roofline" added where its passes carry one: the
// capture's ceilings and each pass's roofline with its time, kept per run
// (the device row holds only the latest capture's device object) and without
// columns of their own (docs/result-schema.md, "extras.roofline").
json extrasWithRoofline(json extras, const json& sample, const json& ceilings) {
  const json* passes = find(sample, "passes");
  if (!passes || !passes->is_array()) return extras;
  json byPass = json::object();
  for (const auto& pass : *passes) {
    const json* roofline = pass.is_object() ? find(pass, "roofline") : nullptr;
    const json* name = pass.is_object() ? find(pass, "name") : nullptr;
    if (!roofline || !roofline->is_object() || !name || !name->is_string()) continue;
    json entry = *roofline;
    if (const json* ms = find(pass, "gpu_ms")) entry["gpu_ms"] = *ms;
    byPass[name->get<std::string>()] = std::move(entry);
  }
  if (byPass.empty()) return extras;
  if (!extras.is_object()) extras = json::object();
  extras["roofline"] = {{"ceilings", ceilings.is_object() ? ceilings : json(nullptr)}, {"passes", std::move(byPass)}};
  return extras;
}

void insertSamples(Inserter& in, int64_t runId, const json& run, const std::string& path,
                   const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  const json& samples = kMembers.array(run, "samples", path);
  for (size_t s = 0; s < samples.size(); ++s) {
    std::string at = path + ".samples[" + std::to_string(s) + "]";
    const json& sample = samples[s];
    if (!sample.is_object()) bad(at, "must be an object");
    const json* camera = find(sample, "camera");
    if (!camera || !camera->is_object()) bad(at + ".camera", "missing or not an object");
    int64_t cameraIndex =
        kMembers.optInteger(*camera, "index", at + ".camera").value_or(static_cast<int64_t>(s));
    // -1: the renderer has no skybox pass.
    std::optional<double> sky;
    if (find(sample, "sky_fraction")) {
      if (double given = kMembers.number(sample, "sky_fraction", at); given >= 0) sky = given;
    }
    ImageErrorColumns image = imageErrorColumns(sample, "image_error", at, "forward");
    // A variant's error against its reference variant; "against" is required
    // there, as no renderer is its implied reference.
    ImageErrorColumns variant = imageErrorColumns(sample, "variant_error", at, std::nullopt);
    auto screenshotId = insertScreenshot(in, sample, at, screenshots);
    auto frames = kMembers.optInteger(sample, "frames", at);
    in.sample.reset();
    in.sample.bind(1, runId)
        .bind(2, cameraIndex)
        .bind(3, *camera)
        .bind(4, sky)
        .bind(5, kMembers.optNumber(sample, "sky_fraction_estimate", at))
        .bind(6, frames)
        .bind(7, kMembers.number(sample, "frame_ms", at))
        .bind(8, optJson(sample, "frame_ms_spread"))
        .bind(9, kMembers.optNumber(sample, "frame_ms_instrumented", at))
        .bind(10, kMembers.optNumber(sample, "overhead_ratio", at))
        .bind(11, image.against)
        .bind(12, image.identical)
        .bind(13, image.psnr)
        .bind(14, image.maxAbs)
        .bind(15, image.meanAbs)
        .bind(16, screenshotId)
        .bind(17, extrasWithRoofline(kMembers.object(sample, "extras", at), sample, in.ceilings))
        .bind(18, variant.against)
        .bind(19, variant.identical)
        .bind(20, variant.psnr)
        .bind(21, variant.maxAbs)
        .bind(22, variant.meanAbs)
        .bind(23, optFrameTimes(sample, "frame_ms_frames", at));
    int64_t sampleId = 0;
    try {
      sampleId = returnedId(in.sample);
    } catch (const DbError& e) {
      bad(at, e.what());  // e.g. a camera index repeated within the run
    }
    in.sums = {};
    insertPasses(in, sampleId, sample, at);
    in.sampleBytes.reset();
    in.sampleBytes.bind(1, sampleId)
        .bind(2, in.sums.bytes)
        .bind(3, in.sums.footprint)
        .bind(4, in.sums.footprintRequested)
        .run();
  }
}

void insertResources(Inserter& in, int64_t runId, const json& list, const std::string& path) {
  for (size_t r = 0; r < list.size(); ++r) {
    std::string at = path + "[" + std::to_string(r) + "]";
    const json& resource = list[r];
    if (!resource.is_object()) bad(at, "must be an object");
    in.resource.reset();
    in.resource.bind(1, runId)
        .bind(2, static_cast<int64_t>(r))
        .bind(3, kMembers.text(resource, "name", at))
        .bind(4, kMembers.text(resource, "kind", at))
        .bind(5, kMembers.optText(resource, "format", at))
        .bind(6, kMembers.optInteger(resource, "element_bytes", at))
        .bind(7, kMembers.optInteger(resource, "width", at))
        .bind(8, kMembers.optInteger(resource, "height", at))
        .bind(9, kMembers.optInteger(resource, "allocation_bytes", at))
        .bind(10, kMembers.optInteger(resource, "format_bytes", at))
        .bind(11, kMembers.optText(resource, "usage", at));
    in.resource.run();
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

int64_t insertRun(Inserter& in, int64_t jobId, int64_t deviceId, const json& shaders, const Build& build,
                  const json& run, const std::string& path, const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  if (!run.is_object()) bad(path, "must be an object");
  in.findScene.reset();
  in.findScene.bind(1, kMembers.text(run, "scene", path)).bind(2, kMembers.object(run, "scene_params", path));
  int64_t sceneId = 0;
  if (in.findScene.step()) {
    sceneId = in.findScene.getInt(0);
    in.findScene.run();
  } else {
    in.scene.reset();
    in.scene.bind(1, kMembers.text(run, "scene", path)).bind(2, kMembers.object(run, "scene_params", path));
    sceneId = returnedId(in.scene);
  }
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
  in.run.reset();
  in.run.bind(1, jobId)
      .bind(2, deviceId)
      .bind(3, kMembers.text(run, "renderer", path))
      .bind(4, sceneId)
      .bind(5, width)
      .bind(6, height)
      .bind(7, kMembers.optText(run, "counting", path).value_or("exact"))
      .bind(8, lights)
      .bind(9, kMembers.optInteger(resources, "render_target_bytes", path + ".resources"))
      .bind(10, kMembers.object(run, "notes", path))
      .bind(11, shaders)
      .bind(12, headroom)
      .bind(13, kMembers.object(run, "options", path))
      .bind(14, kMembers.optText(run, "variant", path).value_or(kMembers.text(run, "renderer", path)))
      .bind(15, build.version)
      .bind(16, build.commit)
      .bind(17, footprintBlock);
  int64_t runId = returnedId(in.run);
  insertResources(in, runId, kMembers.array(resources, "list", path + ".resources"),
                  path + ".resources.list");
  detail::insertShaderSources(in.db, runId, run, path);
  insertSamples(in, runId, run, path, screenshots);
  return runId;
}

// The sweep's row for a job, replacing an earlier one; inside the caller's transaction.
int64_t storeSweep(Connection* db, int64_t jobId, const json& result) {
  // Idempotency, as for captures: the job's result replaces its earlier one.
  Statement drop(db, "DELETE FROM sweeps WHERE job_id = ?1");
  drop.bind(1, jobId).run();
  Inserter in(db);
  int64_t deviceId = insertDevice(in, result);
  const json& failsAt = result["fails_at"];
  Statement insert(db,
                   "INSERT INTO sweeps (job_id, device_id, name, parameters, threshold, fails_at, point_count, "
                   "result) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8) RETURNING id");
  insert.bind(1, jobId)
      .bind(2, deviceId)
      .bind(3, result["sweep"].get<std::string>())
      .bind(4, result["parameters"])
      .bind(5, result["threshold"])
      .bind(6, failsAt.is_null() ? std::optional<json>() : std::optional<json>(failsAt))
      .bind(7, static_cast<int64_t>(result["points"].size()))
      .bind(8, result);
  return returnedId(insert);
}

// A capture's runs for a job, replacing earlier ones; inside the caller's transaction.
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

  Inserter in(db);
  int64_t deviceId = insertDevice(in, result);
  if (const json* device = find(result, "device"); device && device->is_object()) {
    if (const json* c = find(*device, "ceilings"); c && c->is_object()) in.ceilings = *c;
  }
  json shaders = kMembers.object(result, "shaders", "result");
  Build build = buildOf(result);
  const json* runs = find(result, "runs");
  if (!runs || !runs->is_array()) bad("runs", "missing or not an array");
  for (size_t r = 0; r < runs->size(); ++r) {
    insertRun(in, jobId, deviceId, shaders, build, (*runs)[r], "runs[" + std::to_string(r) + "]", screenshots);
  }
  if (host) {
    Statement stamp(db, "UPDATE runs SET host = ?1 WHERE job_id = ?2");
    stamp.bind(1, *host).bind(2, jobId).run();
  }
  return static_cast<int64_t>(runs->size());
}

bool jobExists(Connection* db, int64_t jobId) {
  Statement job(db, "SELECT 1 FROM jobs WHERE id = ?1");
  job.bind(1, jobId);
  bool found = job.step();
  job.run();
  return found;
}

}  // namespace

Result<int64_t> Runs::ingestSweep(int64_t jobId, const json& result) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the sweep result", [&]() -> Result<int64_t> {
    detail::checkSweep(result);
    Transaction tx(db_, Transaction::Kind::Write);
    if (!jobExists(db_, jobId)) return makeError("job " + std::to_string(jobId) + " not found");
    int64_t id = storeSweep(db_, jobId, result);
    tx.commit();
    return id;
  });
}

Result<int64_t> Runs::ingestSweep(const Lease& lease, const json& result) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the sweep result", [&]() -> Result<int64_t> {
    detail::checkSweep(result);
    Transaction tx(db_, Transaction::Kind::Write);
    if (!detail::holdsLease(db_, lease)) return makeError(detail::lostLease(db_, lease));
    int64_t id = storeSweep(db_, lease.jobId, result);
    detail::finishHeld(db_, lease, JobStatus::Done, std::nullopt);
    tx.commit();
    return id;
  });
}

Result<int64_t> Runs::ingestCapture(int64_t jobId, const json& result,
                                    const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the capture result", [&]() -> Result<int64_t> {
    Transaction tx(db_, Transaction::Kind::Write);
    if (!jobExists(db_, jobId)) return makeError("job " + std::to_string(jobId) + " not found");
    int64_t runs = storeCapture(db_, jobId, result, screenshots, std::nullopt);
    tx.commit();
    return runs;
  });
}

Result<int64_t> Runs::ingestCapture(const Lease& lease, const json& result,
                                    const std::map<std::string, std::vector<uint8_t>>& screenshots) {
  if (!result.is_object()) return makeError("result: must be a JSON object");
  std::lock_guard lock(mutex_);
  detail::WriteLock writer(*db_);
  return detail::guarded<int64_t>("ingesting the capture result", [&]() -> Result<int64_t> {
    Transaction tx(db_, Transaction::Kind::Write);
    if (!detail::holdsLease(db_, lease)) return makeError(detail::lostLease(db_, lease));
    int64_t runs = storeCapture(db_, lease.jobId, result, screenshots, lease.host);
    detail::finishHeld(db_, lease, JobStatus::Done, std::nullopt);
    tx.commit();
    return runs;
  });
}

}  // namespace tally::store

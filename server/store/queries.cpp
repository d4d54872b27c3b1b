// Read queries: runs (filtered, cursor-paginated), samples with passes and
// counters, screenshots. Multi-statement reads run in one read transaction,
// so a concurrent re-ingest is seen entirely or not at all.
#include "store/internal.hpp"

namespace tally::store {

using detail::guarded;
using nlohmann::json;

namespace detail {

const char* const kRunSelect =
    "SELECT r.id, r.job_id, r.device_id, d.name, r.renderer, sc.name, sc.params, r.width, r.height, "
    "r.counting, "
    "r.lights, r.render_target_bytes, r.notes, r.created_at, "
    "(SELECT COUNT(*) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT AVG(s.frame_ms) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT AVG(s.bytes) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT AVG(s.frame_ms_instrumented) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT AVG(s.overhead_ratio) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT COUNT(s.image_against) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT COUNT(*) FROM samples s WHERE s.run_id = r.id AND s.image_identical = 1), "
    "(SELECT AVG(s.psnr) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT MIN(s.psnr) FROM samples s WHERE s.run_id = r.id), "
    "r.options, COALESCE(r.variant, r.renderer), r.tally_version, r.tally_commit, r.footprint_block_bytes, "
    "(SELECT AVG(s.footprint_bytes) FROM samples s WHERE s.run_id = r.id), "
    "(SELECT AVG(s.footprint_requested_bytes) FROM samples s WHERE s.run_id = r.id), r.host, "
    "(SELECT j.labels FROM jobs j WHERE j.id = r.job_id) "
    "FROM runs r JOIN devices d ON d.id = r.device_id JOIN scenes sc ON sc.id = r.scene_id";

RunRow readRunRow(const Statement& row) {
  RunRow run;
  run.id = row.getInt(0);
  run.jobId = row.getInt(1);
  run.deviceId = row.getInt(2);
  run.deviceName = row.getText(3);
  run.renderer = row.getText(4);
  run.scene = row.getText(5);
  run.sceneParams = row.getJson(6);
  run.width = static_cast<int>(row.getInt(7));
  run.height = static_cast<int>(row.getInt(8));
  run.counting = row.getText(9);
  run.lights = static_cast<int>(row.getInt(10));
  run.renderTargetBytes = row.getOptInt(11);
  run.notes = row.getJson(12);
  run.createdAt = row.getText(13);
  run.sampleCount = static_cast<int>(row.getInt(14));
  run.meanFrameMs = row.getOptDouble(15);
  run.meanBytes = row.getOptDouble(16);
  run.meanFrameMsInstrumented = row.getOptDouble(17);
  run.meanOverheadRatio = row.getOptDouble(18);
  run.imageCompared = static_cast<int>(row.getInt(19));
  run.imageIdentical = static_cast<int>(row.getInt(20));
  run.meanPsnr = row.getOptDouble(21);
  run.minPsnr = row.getOptDouble(22);
  run.options = row.getJson(23);
  run.variant = row.getText(24);
  run.tallyVersion = row.getOptText(25);
  run.tallyCommit = row.getOptText(26);
  run.footprintBlockBytes = row.getOptInt(27);
  run.meanFootprintBytes = row.getOptDouble(28);
  run.meanFootprintRequestedBytes = row.getOptDouble(29);
  run.host = row.getOptText(30);
  run.labels = row.isNull(31) ? json::object() : row.getJson(31);
  return run;
}

// Fixed SQL fragments only; the values are bound by bindRunFilter in the same order.
std::string runFilterSql(const RunFilter& f) {
  std::string sql;
  if (f.renderer) sql += " AND r.renderer = ?";
  if (f.variant) sql += " AND r.variant = ?";
  if (f.scene) sql += " AND r.scene_id IN (SELECT id FROM scenes WHERE name = ?)";
  if (f.width) sql += " AND r.width = ?";
  if (f.height) sql += " AND r.height = ?";
  if (f.deviceId) sql += " AND r.device_id = ?";
  if (f.deviceName) sql += " AND r.device_id IN (SELECT id FROM devices WHERE name = ?)";
  if (f.jobId) sql += " AND r.job_id = ?";
  if (f.host) sql += " AND r.host = ?";
  for (size_t i = 0; i < f.labels.size(); ++i) {
    sql += " AND r.job_id IN (SELECT job_id FROM job_labels WHERE name = ? AND value = ?)";  // placeholders only
  }
  if (!f.runIds.empty()) {
    sql += " AND r.id IN (?";
    for (size_t i = 1; i < f.runIds.size(); ++i) sql += ", ?";  // placeholders only
    sql += ")";
  }
  if (f.createdSince) sql += " AND r.created_at >= ?";
  if (f.createdUntil) sql += " AND substr(r.created_at, 1, ?) <= ?";
  return sql;
}

int bindRunFilter(Statement& statement, const RunFilter& f, int first) {
  int i = first;
  if (f.renderer) statement.bind(i++, *f.renderer);
  if (f.variant) statement.bind(i++, *f.variant);
  if (f.scene) statement.bind(i++, *f.scene);
  if (f.width) statement.bind(i++, *f.width);
  if (f.height) statement.bind(i++, *f.height);
  if (f.deviceId) statement.bind(i++, *f.deviceId);
  if (f.deviceName) statement.bind(i++, *f.deviceName);
  if (f.jobId) statement.bind(i++, *f.jobId);
  if (f.host) statement.bind(i++, *f.host);
  for (const auto& [name, value] : f.labels) {
    statement.bind(i++, name);
    statement.bind(i++, value);
  }
  for (int64_t id : f.runIds) statement.bind(i++, id);
  if (f.createdSince) statement.bind(i++, *f.createdSince);
  if (f.createdUntil) {
    statement.bind(i++, static_cast<int64_t>(f.createdUntil->size()));
    statement.bind(i++, *f.createdUntil);
  }
  return i;
}

}  // namespace detail

namespace {

const char* const kSampleColumns =
    "id, run_id, camera_index, camera, sky_fraction, sky_fraction_estimate, frames, frame_ms, "
    "frame_ms_spread, "
    "frame_ms_instrumented, overhead_ratio, bytes, image_against, image_identical, psnr, max_abs, mean_abs, "
    "screenshot_id IS NOT NULL, "
    "(SELECT COALESCE(SUM(c.bytes), 0) FROM passes p JOIN counters c ON c.pass_id = p.id "
    "WHERE p.sample_id = samples.id AND c.access = 'read'), "
    "(SELECT COALESCE(SUM(c.bytes), 0) FROM passes p JOIN counters c ON c.pass_id = p.id "
    "WHERE p.sample_id = samples.id AND c.access = 'write'), "
    "extras, variant_against, variant_identical, variant_psnr, variant_max_abs, variant_mean_abs, "
    "footprint_bytes, footprint_requested_bytes";

SampleRow readSampleRow(const Statement& row) {
  SampleRow s;
  s.id = row.getInt(0);
  s.runId = row.getInt(1);
  s.cameraIndex = static_cast<int>(row.getInt(2));
  s.camera = row.getJson(3);
  s.skyFraction = row.getOptDouble(4);
  s.skyFractionEstimate = row.getOptDouble(5);
  if (auto frames = row.getOptInt(6)) s.frames = static_cast<int>(*frames);
  s.frameMs = row.getDouble(7);
  s.frameMsSpread = row.getJson(8);
  s.frameMsInstrumented = row.getOptDouble(9);
  s.overheadRatio = row.getOptDouble(10);
  s.bytes = row.getDouble(11);
  if (auto against = row.getOptText(12)) {
    ImageError e;
    e.against = *against;
    e.identical = row.getInt(13) != 0;
    e.psnr = row.getOptDouble(14);
    e.maxAbs = row.getDouble(15);
    e.meanAbs = row.getDouble(16);
    s.imageError = e;
  }
  s.hasScreenshot = row.getInt(17) != 0;
  s.bytesRead = row.getDouble(18);
  s.bytesWritten = row.getDouble(19);
  s.extras = row.getJson(20);
  if (auto against = row.getOptText(21)) {
    ImageError e;
    e.against = *against;
    e.identical = row.getInt(22) != 0;
    e.psnr = row.getOptDouble(23);
    e.maxAbs = row.getDouble(24);
    e.meanAbs = row.getDouble(25);
    s.variantError = e;
  }
  s.footprintBytes = row.getOptDouble(26);
  s.footprintRequestedBytes = row.getOptDouble(27);
  return s;
}

// A stored per-frame array (0008; JSON, NULL before): empty when absent.
std::vector<double> frameTimes(const Statement& row, int column) {
  std::vector<double> out;
  nlohmann::json value = row.getJson(column);
  if (!value.is_array()) return out;
  out.reserve(value.size());
  for (const auto& ms : value)
    if (ms.is_number()) out.push_back(ms.get<double>());
  return out;
}

std::optional<RunRow> findRunRow(Connection* db, int64_t runId) {
  Statement query(db, std::string(detail::kRunSelect) + " WHERE r.id = ?1");
  query.bind(1, runId);
  if (!query.step()) return std::nullopt;
  return detail::readRunRow(query);
}

}  // namespace

Result<RunPage> Store::listRuns(const RunFilter& filter, const Page& page) {
  auto checked = detail::checkPage(page);
  if (!checked) return makeError(checked.error());
  std::optional<int64_t> after = *checked;
  if (filter.runIds.size() > 1000) return makeError("runs: at most 1000 run ids");
  std::lock_guard lock(mutex_);
  return guarded<RunPage>("listRuns", [&]() -> Result<RunPage> {
    // The page's ids first, then the summary columns of those runs only. A
    // filter that the index cannot return in id order (a device or scene
    // name matching several ids) makes SQLite sort, and it computes every
    // result column, the per-run sample aggregates included, before it sorts.
    std::string sql = std::string(detail::kRunSelect) + " WHERE r.id IN (SELECT r.id FROM runs r WHERE TRUE" +
                      detail::runFilterSql(filter);
    if (after) sql += " AND r.id < ?";
    sql += " ORDER BY r.id DESC LIMIT ?) ORDER BY r.id DESC";
    Statement query(db_, sql);
    int next = detail::bindRunFilter(query, filter, 1);
    if (after) query.bind(next++, *after);
    query.bind(next, page.limit + 1);  // one more tells whether another page follows
    RunPage out;
    while (query.step()) {
      if (static_cast<int>(out.runs.size()) == page.limit) {
        out.nextCursor = encodeCursor(out.runs.back().id);
        break;
      }
      out.runs.push_back(detail::readRunRow(query));
    }
    return out;
  });
}

Result<std::vector<Device>> Store::listDevices() {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<Device>>("listDevices", [&]() -> Result<std::vector<Device>> {
    Statement query(db_,
                    "SELECT id, name, vendor, driver, api_version, features, info FROM devices ORDER BY id");
    std::vector<Device> devices;
    while (query.step()) {
      devices.push_back(Device{query.getInt(0), query.getText(1), query.getText(2), query.getText(3),
                               query.getText(4), query.getJson(5), query.getJson(6)});
    }
    return devices;
  });
}

Result<std::optional<Run>> Store::getRun(int64_t runId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Run>>("getRun", [&]() -> Result<std::optional<Run>> {
    Transaction tx(db_, Transaction::Kind::Read);
    auto row = findRunRow(db_, runId);
    if (!row) return std::optional<Run>();
    Run run;
    run.row = std::move(*row);
    Statement device(db_,
                     "SELECT d.id, d.name, d.vendor, d.driver, d.api_version, d.features, d.info, r.shaders, "
                     "r.counter_headroom FROM runs r JOIN devices d ON d.id = r.device_id WHERE r.id = ?1");
    device.bind(1, runId);
    if (device.step()) {
      run.device = Device{device.getInt(0),  device.getText(1), device.getText(2), device.getText(3),
                          device.getText(4), device.getJson(5), device.getJson(6)};
      run.shaders = device.getJson(7);
      run.counterHeadroom = device.getJson(8);
    }
    Statement ceilings(
        db_, db_->engine() == Engine::Sqlite
                 ? "SELECT json_extract(extras, '$.roofline.ceilings') FROM samples WHERE run_id = ?1 AND "
                   "json_type(extras, '$.roofline.ceilings') = 'object' ORDER BY camera_index LIMIT 1"
                 : "SELECT CAST(CAST(extras AS jsonb) -> 'roofline' -> 'ceilings' AS text) FROM samples "
                   "WHERE run_id = ?1 AND jsonb_typeof(CAST(extras AS jsonb) -> 'roofline' -> 'ceilings') = "
                   "'object' ORDER BY camera_index LIMIT 1");
    ceilings.bind(1, runId);
    run.ceilings = ceilings.step() ? ceilings.getJson(0) : nlohmann::json(nullptr);
    Statement resources(
        db_,
        "SELECT name, kind, format, element_bytes, width, height, allocation_bytes, format_bytes, "
        "usage FROM run_resources WHERE run_id = ?1 ORDER BY position");
    resources.bind(1, runId);
    while (resources.step()) {
      run.resources.push_back(RunResource{resources.getText(0), resources.getText(1), resources.getOptText(2),
                                          resources.getOptInt(3), resources.getOptInt(4),
                                          resources.getOptInt(5), resources.getOptInt(6),
                                          resources.getOptInt(7), resources.getOptText(8)});
    }
    tx.commit();
    return std::optional<Run>(std::move(run));
  });
}

Result<std::vector<SampleRow>> Store::listSamples(int64_t runId) {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<SampleRow>>("listSamples", [&]() -> Result<std::vector<SampleRow>> {
    Statement query(db_, std::string("SELECT ") + kSampleColumns +
                             " FROM samples WHERE run_id = ?1 ORDER BY camera_index");
    query.bind(1, runId);
    std::vector<SampleRow> rows;
    while (query.step()) rows.push_back(readSampleRow(query));
    return rows;
  });
}

Result<std::optional<Sample>> Store::getSample(int64_t sampleId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Sample>>("getSample", [&]() -> Result<std::optional<Sample>> {
    Transaction tx(db_, Transaction::Kind::Read);
    // frame_ms_frames comes after kSampleColumns' 28 columns: only this query reads it.
    Statement query(db_, std::string("SELECT ") + kSampleColumns + ", frame_ms_frames FROM samples WHERE id = ?1");
    query.bind(1, sampleId);
    if (!query.step()) return std::optional<Sample>();
    Sample sample;
    sample.row = readSampleRow(query);
    sample.row.frameMsFrames = frameTimes(query, 28);
    Statement passes(db_,
                     "SELECT id, name, gpu_ms, gpu_ms_spread, gpu_ms_instrumented, overhead_ratio, "
                     "fragment_invocations, fragment_invocations_statistic, compute_invocations, "
                     "compute_invocations_statistic, gpu_ms_frames FROM passes WHERE sample_id = ?1 "
                     "ORDER BY position");
    passes.bind(1, sampleId);
    std::map<int64_t, size_t> byId;
    while (passes.step()) {
      byId[passes.getInt(0)] = sample.passes.size();
      sample.passes.push_back(Pass{passes.getText(1),
                                   passes.getDouble(2),
                                   passes.getJson(3),
                                   passes.getOptDouble(4),
                                   passes.getOptDouble(5),
                                   passes.getOptDouble(6),
                                   passes.getOptDouble(7),
                                   {},
                                   passes.getOptDouble(8),
                                   passes.getOptDouble(9),
                                   frameTimes(passes, 10)});
    }
    Statement counters(
        db_,
        "SELECT c.pass_id, c.resource, c.kind, c.format, c.access, c.count, c.bytes, c.count_spread, "
        "c.source, c.footprint_bytes FROM counters c JOIN passes p ON p.id = c.pass_id WHERE p.sample_id = ?1 "
        "ORDER BY p.position, c.position");
    counters.bind(1, sampleId);
    while (counters.step()) {
      sample.passes[byId.at(counters.getInt(0))].counters.push_back(
          Counter{counters.getText(1), counters.getOptText(2), counters.getOptText(3), counters.getText(4),
                  counters.getDouble(5), counters.getDouble(6), counters.getJson(7), counters.getText(8),
                  counters.getOptDouble(9)});
    }
    tx.commit();
    return std::optional<Sample>(std::move(sample));
  });
}

Result<std::optional<std::vector<uint8_t>>> Store::getScreenshot(int64_t sampleId) {
  std::lock_guard lock(mutex_);
  using Png = std::optional<std::vector<uint8_t>>;
  return guarded<Png>("getScreenshot", [&]() -> Result<Png> {
    Statement query(
        db_, "SELECT sh.png FROM samples s JOIN screenshots sh ON sh.id = s.screenshot_id WHERE s.id = ?1");
    query.bind(1, sampleId);
    if (!query.step()) return Png();
    return Png(query.getBlob(0));
  });
}

}  // namespace tally::store

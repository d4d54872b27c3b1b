// Read queries: runs (filtered, cursor-paginated), samples with passes and
// counters, screenshots. Multi-statement reads run in one read transaction,
// so a concurrent re-ingest is seen entirely or not at all.
#include <algorithm>
#include <stdexcept>

#include "store/count_spread.hpp"
#include "store/internal.hpp"

namespace tally::store {

using detail::guarded;
using nlohmann::json;

namespace detail {

std::string runSelect(const Connection&, std::string_view where) {
  // The run's summary over its samples and its frame time are columns of
  // the run (migration 0013, written at ingest): no walk over the samples.
  std::string sql =
      "SELECT r.id, r.job_id, r.device_id, d.name, r.renderer, sc.name, sc.params, r.width, r.height, "
      "r.counting, r.lights, r.render_target_bytes, r.notes, r.created_at, r.sample_count, r.mean_frame_ms, "
      "r.mean_bytes, r.mean_frame_ms_instrumented, r.mean_overhead_ratio, r.image_compared, r.image_identical, "
      "r.mean_psnr, r.min_psnr, r.options, COALESCE(r.variant, r.renderer), r.tally_version, r.tally_commit, "
      "r.footprint_block_bytes, r.mean_footprint_bytes, r.mean_footprint_requested_bytes, r.host, j.labels, "
      "r.frame_time_median, r.frame_time_lower, r.frame_time_upper, r.frame_time_frames, r.frame_time_source "
      "FROM runs r JOIN devices d ON d.id = r.device_id JOIN scenes sc ON sc.id = r.scene_id "
      "LEFT JOIN jobs j ON j.id = r.job_id ";
  sql += where;
  return sql;
}

RunRow readRunRow(const Statement& statement) {
  RowReader row(statement);
  RunRow run;
  run.id = row.getInt();
  run.jobId = row.getInt();
  run.deviceId = row.getInt();
  run.deviceName = row.getText();
  run.renderer = row.getText();
  run.scene = row.getText();
  run.sceneParams = row.getJson();
  run.width = static_cast<int>(row.getInt());
  run.height = static_cast<int>(row.getInt());
  run.counting = row.getText();
  run.lights = static_cast<int>(row.getInt());
  run.renderTargetBytes = row.getOptInt();
  run.notes = row.getJson();
  run.createdAt = row.getText();
  run.sampleCount = static_cast<int>(row.getInt());
  run.meanFrameMs = row.getOptDouble();
  run.meanBytes = row.getOptDouble();
  run.meanFrameMsInstrumented = row.getOptDouble();
  run.meanOverheadRatio = row.getOptDouble();
  run.imageCompared = static_cast<int>(row.getInt());
  run.imageIdentical = static_cast<int>(row.getInt());
  run.meanPsnr = row.getOptDouble();
  run.minPsnr = row.getOptDouble();
  run.options = row.getJson();
  run.variant = row.getText();
  run.tallyVersion = row.getOptText();
  run.tallyCommit = row.getOptText();
  run.footprintBlockBytes = row.getOptInt();
  run.meanFootprintBytes = row.getOptDouble();
  run.meanFootprintRequestedBytes = row.getOptDouble();
  run.host = row.getOptText();
  json labels = row.getJson();
  run.labels = labels.is_null() ? json::object() : std::move(labels);
  auto median = row.getOptDouble(), lower = row.getOptDouble(), upper = row.getOptDouble();
  auto frames = row.getOptInt();
  if (auto source = row.getOptText()) {  // NULL: stored before 0013, computed by the reader
    run.frameTime = RunFrameTime{median, lower, upper, static_cast<size_t>(frames.value_or(0)), std::move(*source)};
  }
  row.end();
  return run;
}

Device readDevice(RowReader& row) {
  return Device{row.getInt(),  row.getText(), row.getText(), row.getText(),
                row.getText(), row.getJson(), row.getJson()};
}

namespace {

// "unnest(p.counter_bytes, ...) WITH ORDINALITY AS c(bytes, ..., position)".
std::string unnestedCounters(std::initializer_list<std::string_view> columns) {
  std::string arrays, names;
  for (std::string_view column : columns) {
    auto it = std::find_if(std::begin(kCounterArrays), std::end(kCounterArrays),
                           [&](const CounterArray& a) { return a.column == column; });
    if (it == std::end(kCounterArrays)) throw std::logic_error("no counter array for column " + std::string(column));
    arrays += (arrays.empty() ? "p." : ", p.") + std::string(it->array);
    names += std::string(column) + ", ";
  }
  return "unnest(" + arrays + ") WITH ORDINALITY AS c(" + names + "position)";
}

}  // namespace

std::string joinPassCounters(const Connection& db, std::initializer_list<std::string_view> columns) {
  if (db.engine() == Engine::Sqlite) return " JOIN counters c ON c.pass_id = p.id";
  return " CROSS JOIN LATERAL " + unnestedCounters(columns);
}

std::string countersOfPass(const Connection& db, std::initializer_list<std::string_view> columns) {
  if (db.engine() == Engine::Sqlite) return "counters c WHERE c.pass_id = p.id";
  return unnestedCounters(columns) + " WHERE TRUE";
}

std::string parameterList(size_t n) {
  std::string out = "?";
  for (size_t i = 1; i < n; ++i) out += ", ?";
  return out;
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
  if (!f.runIds.empty()) sql += " AND r.id IN (" + parameterList(f.runIds.size()) + ")";
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

std::string sampleColumns(const Connection& db) {
  std::string bytesOf = "(SELECT COALESCE(SUM(c.bytes), 0) FROM passes p" +
                        detail::joinPassCounters(db, {"bytes", "access"}) +
                        " WHERE p.sample_id = samples.id AND c.access = ";
  return "id, run_id, camera_index, camera, sky_fraction, sky_fraction_estimate, frames, frame_ms, "
         "frame_ms_spread, "
         "frame_ms_instrumented, overhead_ratio, bytes, image_against, image_identical, psnr, max_abs, mean_abs, "
         "screenshot_id IS NOT NULL, " +
         bytesOf + "'read'), " + bytesOf +
         "'write'), "
         "extras, variant_against, variant_identical, variant_psnr, variant_max_abs, variant_mean_abs, "
         "footprint_bytes, footprint_requested_bytes";
}

// An image error's five columns (against, identical, psnr, max_abs,
// mean_abs), all read; empty when there is no error (against is NULL).
std::optional<ImageError> readImageError(RowReader& row) {
  auto against = row.getOptText();
  ImageError e;
  e.identical = row.getInt() != 0;
  e.psnr = row.getOptDouble();
  e.maxAbs = row.getDouble();
  e.meanAbs = row.getDouble();
  if (!against) return std::nullopt;
  e.against = *against;
  return e;
}

// Reads sampleColumns(); the caller reads whatever its query adds after them.
SampleRow readSampleRow(RowReader& row) {
  SampleRow s;
  s.id = row.getInt();
  s.runId = row.getInt();
  s.cameraIndex = static_cast<int>(row.getInt());
  s.camera = row.getJson();
  s.skyFraction = row.getOptDouble();
  s.skyFractionEstimate = row.getOptDouble();
  if (auto frames = row.getOptInt()) s.frames = static_cast<int>(*frames);
  s.frameMs = row.getDouble();
  s.frameMsSpread = row.getJson();
  s.frameMsInstrumented = row.getOptDouble();
  s.overheadRatio = row.getOptDouble();
  s.bytes = row.getDouble();
  s.imageError = readImageError(row);
  s.hasScreenshot = row.getInt() != 0;
  s.bytesRead = row.getDouble();
  s.bytesWritten = row.getDouble();
  s.extras = row.getJson();
  s.variantError = readImageError(row);
  s.footprintBytes = row.getOptDouble();
  s.footprintRequestedBytes = row.getOptDouble();
  return s;
}

// A stored per-frame array (0008; JSON, NULL before): empty when absent.
std::vector<double> frameTimes(RowReader& row) {
  std::vector<double> out;
  nlohmann::json value = row.getJson();
  if (!value.is_array()) return out;
  out.reserve(value.size());
  for (const auto& ms : value)
    if (ms.is_number()) out.push_back(ms.get<double>());
  return out;
}

// PostgreSQL plans the listing's prepared statement anew at every execution
// (its custom plans cost less than the generic one, whose LIMIT it cannot
// see): 0.45 ms of planning for 0.25 ms of execution at 1M samples, for the
// same index walk as the generic plan (docs/benchmarks.md, "The runs
// listing's JSON written as text"). While this lives, the connection uses
// the generic plan; only this statement's, whose plans the read benchmark
// checks (no sequential scan); every other keeps the server's default.
class GenericPlan {
 public:
  explicit GenericPlan(Connection* db) : db_(db->engine() == Engine::Postgres ? db : nullptr) {
    if (db_) db_->exec("SET plan_cache_mode = force_generic_plan");
  }
  ~GenericPlan() {
    if (!db_) return;
    try {
      db_->exec("RESET plan_cache_mode");
    } catch (const std::exception&) {
      // Not thrown from a destructor. A connection that cannot take a RESET
      // has failed, and its next statement fails as well.
    }
  }
  GenericPlan(const GenericPlan&) = delete;
  GenericPlan& operator=(const GenericPlan&) = delete;

 private:
  Connection* db_;
};

std::optional<RunRow> findRunRow(Connection* db, int64_t runId) {
  Statement query(db, detail::runSelect(*db, "WHERE r.id = ?1"));
  query.bind(1, runId);
  if (!query.step()) return std::nullopt;
  return detail::readRunRow(query);
}

}  // namespace

Result<RunPage> Runs::list(const RunFilter& filter, const Page& page) {
  auto checked = detail::checkPage(page);
  if (!checked) return makeError(checked.error());
  std::optional<int64_t> after = *checked;
  if (filter.runIds.size() > 1000) return makeError("runs: at most 1000 run ids");
  std::lock_guard lock(mutex_);
  return guarded<RunPage>("listRuns", [&]() -> Result<RunPage> {
    // The page's ids first, then the columns of those runs only (a filter
    // that the index cannot return in id order, a device or scene name
    // matching several ids, makes SQLite sort, and it reads every result
    // column before it sorts). One statement whatever the page size; the
    // run's summary over its samples is on its row (0013).
    std::string pageIds = "SELECT r.id FROM runs r WHERE TRUE" + detail::runFilterSql(filter);
    if (after) pageIds += " AND r.id < ?";
    pageIds += " ORDER BY r.id DESC LIMIT ?";
    // PostgreSQL: the page's ids as an array computed once, so that every
    // plan fetches the runs by key. With "IN (subquery)", a generic plan
    // (which does not know LIMIT's value and guesses a tenth of the rows)
    // hash-joins a scan of every run.
    std::string ids = db_->engine() == Engine::Postgres ? "WHERE r.id = ANY(ARRAY(" + pageIds + "))"
                                                         : "WHERE r.id IN (" + pageIds + ")";
    std::string sql = detail::runSelect(*db_, ids) + " ORDER BY r.id DESC";
    GenericPlan generic(db_);
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

Result<std::vector<Device>> Runs::devices() {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<Device>>("listDevices", [&]() -> Result<std::vector<Device>> {
    Statement query(db_,
                    "SELECT id, name, vendor, driver, api_version, features, info FROM devices ORDER BY id");
    std::vector<Device> devices;
    while (query.step()) {
      RowReader row(query);
      devices.push_back(detail::readDevice(row));
      row.end();
    }
    return devices;
  });
}

Result<std::optional<Run>> Runs::get(int64_t runId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Run>>("getRun", [&]() -> Result<std::optional<Run>> {
    Transaction tx(db_, Transaction::Kind::Read);
    auto run = detail::readRun(db_, runId);
    tx.commit();
    return run;
  });
}

Result<std::optional<RunDetail>> Runs::detail(int64_t runId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<RunDetail>>("getRunDetail", [&]() -> Result<std::optional<RunDetail>> {
    Transaction tx(db_, Transaction::Kind::Read);
    auto run = detail::readRun(db_, runId);
    if (!run) return std::optional<RunDetail>();
    // The run's sample count is on its row (0013), kept by the ingest in the
    // transaction that stores the samples: no COUNT(*) as passes() needs.
    std::vector<Pass> passes = detail::readRunPasses(db_, runId, run->row.sampleCount);
    tx.commit();
    return std::optional<RunDetail>(RunDetail{std::move(*run), std::move(passes)});
  });
}

namespace detail {

std::optional<Run> readRun(Connection* db, int64_t runId) {
  auto row = findRunRow(db, runId);
  if (!row) return std::nullopt;
  Run run;
  run.row = std::move(*row);
  // The device, and the run's ceilings in the same statement. The text's
  // test comes first, so that a sample whose extras cannot hold ceilings is
  // not parsed as JSON (at 1M on PostgreSQL, warm: 0.045 ms against 0.070
  // for a run without ceilings). The store writes extras as dump() does, so
  // a "ceilings" key is always in the text as the word.
  const char* ceilings =
      db->engine() == Engine::Sqlite
          ? "(SELECT json_extract(extras, '$.roofline.ceilings') FROM samples WHERE run_id = r.id AND "
            "instr(extras, 'ceilings') > 0 AND json_type(extras, '$.roofline.ceilings') = 'object' "
            "ORDER BY camera_index LIMIT 1)"
          : "(SELECT CAST(CAST(extras AS jsonb) -> 'roofline' -> 'ceilings' AS text) FROM samples "
            "WHERE run_id = r.id AND strpos(extras, 'ceilings') > 0 AND "
            "jsonb_typeof(CAST(extras AS jsonb) -> 'roofline' -> 'ceilings') = 'object' "
            "ORDER BY camera_index LIMIT 1)";
  Statement device(db, std::string("SELECT d.id, d.name, d.vendor, d.driver, d.api_version, d.features, d.info, "
                                   "r.shaders, r.counter_headroom, ") +
                           ceilings + " FROM runs r JOIN devices d ON d.id = r.device_id WHERE r.id = ?1");
  device.bind(1, runId);
  run.ceilings = nullptr;
  if (device.step()) {
    RowReader columns(device);
    run.device = detail::readDevice(columns);
    run.shaders = columns.getJson();
    run.counterHeadroom = columns.getJson();
    run.ceilings = columns.getJson();
    columns.end();
  }
  Statement resources(
      db,
      "SELECT name, kind, format, element_bytes, width, height, allocation_bytes, format_bytes, "
      "usage FROM run_resources WHERE run_id = ?1 ORDER BY position");
  resources.bind(1, runId);
  while (resources.step()) {
    RowReader resource(resources);  // a braced list reads its columns in order
    run.resources.push_back(RunResource{resource.getText(), resource.getText(), resource.getOptText(),
                                        resource.getOptInt(), resource.getOptInt(), resource.getOptInt(),
                                        resource.getOptInt(), resource.getOptInt(), resource.getOptText()});
    resource.end();
  }
  return run;
}

}  // namespace detail

Result<std::vector<SampleRow>> Runs::samples(int64_t runId) {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<SampleRow>>("listSamples", [&]() -> Result<std::vector<SampleRow>> {
    Statement query(db_, "SELECT " + sampleColumns(*db_) +
                             " FROM samples WHERE run_id = ?1 ORDER BY camera_index");
    query.bind(1, runId);
    std::vector<SampleRow> rows;
    while (query.step()) {
      RowReader row(query);
      rows.push_back(readSampleRow(row));
      row.end();
    }
    return rows;
  });
}

Result<std::vector<SampleFrameTimes>> Runs::sampleFrameTimes(int64_t runId) {
  auto byRun = sampleFrameTimes(std::span<const int64_t>(&runId, 1));
  if (!byRun) return makeError(byRun.error());
  return std::move((*byRun)[runId]);
}

Result<std::map<int64_t, std::vector<SampleFrameTimes>>> Runs::sampleFrameTimes(std::span<const int64_t> runIds) {
  using ByRun = std::map<int64_t, std::vector<SampleFrameTimes>>;
  std::lock_guard lock(mutex_);
  return guarded<ByRun>("sampleFrameTimes", [&]() -> Result<ByRun> {
    ByRun out;
    // At most kChunk ids a statement (SQLite binds at most 32,766 values; a
    // listing's page is at most 1,000 runs, one statement).
    constexpr size_t kChunk = 1000;
    for (size_t first = 0; first < runIds.size(); first += kChunk) {
      auto chunk = runIds.subspan(first, std::min(kChunk, runIds.size() - first));
      Statement query(db_, "SELECT run_id, frame_ms, frame_ms_frames FROM samples WHERE run_id IN (" +
                               detail::parameterList(chunk.size()) + ") ORDER BY run_id, camera_index");
      for (size_t i = 0; i < chunk.size(); ++i) query.bind(static_cast<int>(i + 1), chunk[i]);
      while (query.step()) {
        RowReader row(query);
        int64_t run = row.getInt();
        SampleFrameTimes s;
        s.frameMs = row.getDouble();
        s.frames = frameTimes(row);
        row.end();
        out[run].push_back(std::move(s));
      }
    }
    return out;
  });
}

Result<std::optional<Sample>> Runs::sample(int64_t sampleId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Sample>>("getSample", [&]() -> Result<std::optional<Sample>> {
    Transaction tx(db_, Transaction::Kind::Read);
    // frame_ms_frames comes after sampleColumns(): only this query reads it.
    Statement query(db_, "SELECT " + sampleColumns(*db_) + ", frame_ms_frames FROM samples WHERE id = ?1");
    query.bind(1, sampleId);
    if (!query.step()) return std::optional<Sample>();
    Sample sample;
    RowReader row(query);
    sample.row = readSampleRow(row);
    sample.row.frameMsFrames = frameTimes(row);
    row.end();
    Statement passes(db_,
                     "SELECT id, name, gpu_ms, gpu_ms_spread, gpu_ms_instrumented, overhead_ratio, "
                     "fragment_invocations, fragment_invocations_statistic, compute_invocations, "
                     "compute_invocations_statistic, gpu_ms_frames FROM passes WHERE sample_id = ?1 "
                     "ORDER BY position");
    passes.bind(1, sampleId);
    std::map<int64_t, size_t> byId;
    while (passes.step()) {
      RowReader pass(passes);
      byId[pass.getInt()] = sample.passes.size();
      sample.passes.push_back(Pass{pass.getText(),
                                   pass.getDouble(),
                                   pass.getJson(),
                                   pass.getOptDouble(),
                                   pass.getOptDouble(),
                                   pass.getOptDouble(),
                                   pass.getOptDouble(),
                                   {},
                                   pass.getOptDouble(),
                                   pass.getOptDouble(),
                                   frameTimes(pass)});
      pass.end();
    }
    Statement counters(
        db_,
        "SELECT p.id, c.resource, c.kind, c.format, c.access, c.count, c.bytes, c.count_spread, c.source, "
        "c.footprint_bytes FROM passes p" +
            detail::joinPassCounters(*db_, {"resource", "kind", "format", "access", "count", "bytes", "count_spread",
                                            "source", "footprint_bytes"}) +
            " WHERE p.sample_id = ?1 ORDER BY p.position, c.position");
    counters.bind(1, sampleId);
    while (counters.step()) {
      RowReader counter(counters);
      size_t pass = byId.at(counter.getInt());
      Counter read{counter.getText(), counter.getOptText(), counter.getOptText(), counter.getText(),
                   counter.getDouble(), counter.getDouble(), counter.getJson(), counter.getText(),
                   counter.getOptDouble()};
      read.countSpread = expandCountSpread(std::move(read.countSpread), read.count);
      sample.passes[pass].counters.push_back(std::move(read));
      counter.end();
    }
    tx.commit();
    return std::optional<Sample>(std::move(sample));
  });
}

Result<std::optional<std::vector<uint8_t>>> Runs::screenshot(int64_t sampleId) {
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

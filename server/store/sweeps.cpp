// Read queries of stored sweeps: the list (filtered, cursor-paginated as
// Runs::list), one sweep with its whole result, and a job's sweeps.
#include "store/internal.hpp"

namespace tally::store {

using detail::guarded;
using nlohmann::json;

namespace {

// Columns read by readSweepRow, then the FROM clause; sweep() adds s.result after them.
const char* const kSweepColumns =
    "SELECT s.id, s.job_id, s.name, s.parameters, s.threshold, s.fails_at, s.point_count, s.created_at, "
    "d.id, d.name, d.vendor, d.driver, d.api_version, d.features, d.info";
const char* const kSweepFrom = " FROM sweeps s JOIN devices d ON d.id = s.device_id";

// Reads kSweepColumns; sweep() reads s.result after them.
SweepRow readSweepRow(RowReader& row) {
  SweepRow s;
  s.id = row.getInt();
  s.jobId = row.getInt();
  s.name = row.getText();
  s.parameters = row.getJson();
  s.threshold = row.getJson();
  s.failsAt = row.getJson();
  s.pointCount = row.getInt();
  s.createdAt = row.getText();
  s.device = detail::readDevice(row);
  return s;
}

// Fixed SQL fragments only; bindSweepFilter binds their values in the same order.
std::string sweepFilterSql(const SweepFilter& f) {
  std::string sql;
  if (f.name) sql += " AND s.name = ?";
  if (f.deviceId) sql += " AND s.device_id = ?";
  if (f.deviceName) sql += " AND s.device_id IN (SELECT id FROM devices WHERE name = ?)";
  if (f.jobId) sql += " AND s.job_id = ?";
  if (f.createdSince) sql += " AND s.created_at >= ?";
  if (f.createdUntil) sql += " AND substr(s.created_at, 1, ?) <= ?";
  return sql;
}

int bindSweepFilter(Statement& statement, const SweepFilter& f, int first) {
  int i = first;
  if (f.name) statement.bind(i++, *f.name);
  if (f.deviceId) statement.bind(i++, *f.deviceId);
  if (f.deviceName) statement.bind(i++, *f.deviceName);
  if (f.jobId) statement.bind(i++, *f.jobId);
  if (f.createdSince) statement.bind(i++, *f.createdSince);
  if (f.createdUntil) {
    statement.bind(i++, static_cast<int64_t>(f.createdUntil->size()));
    statement.bind(i++, *f.createdUntil);
  }
  return i;
}

}  // namespace

Result<SweepPage> Runs::sweeps(const SweepFilter& filter, const Page& page) {
  auto checked = detail::checkPage(page);
  if (!checked) return makeError(checked.error());
  std::optional<int64_t> after = *checked;
  std::lock_guard lock(mutex_);
  return guarded<SweepPage>("listSweeps", [&]() -> Result<SweepPage> {
    std::string sql = std::string(kSweepColumns) + kSweepFrom + " WHERE TRUE" + sweepFilterSql(filter);
    if (after) sql += " AND s.id < ?";
    sql += " ORDER BY s.id DESC LIMIT ?";
    Statement query(db_, sql);
    int next = bindSweepFilter(query, filter, 1);
    if (after) query.bind(next++, *after);
    query.bind(next, page.limit + 1);  // one more tells whether another page follows
    SweepPage out;
    while (query.step()) {
      if (static_cast<int>(out.sweeps.size()) == page.limit) {
        out.nextCursor = encodeCursor(out.sweeps.back().id);
        break;
      }
      RowReader row(query);
      out.sweeps.push_back(readSweepRow(row));
      row.end();
    }
    return out;
  });
}

Result<std::optional<Sweep>> Runs::sweep(int64_t sweepId) {
  std::lock_guard lock(mutex_);
  return guarded<std::optional<Sweep>>("getSweep", [&]() -> Result<std::optional<Sweep>> {
    Statement query(db_, std::string(kSweepColumns) + ", s.result" + kSweepFrom + " WHERE s.id = ?1");
    query.bind(1, sweepId);
    if (!query.step()) return std::optional<Sweep>();
    RowReader row(query);
    Sweep sweep{readSweepRow(row), row.getJson()};
    row.end();
    return std::optional<Sweep>(std::move(sweep));
  });
}

Result<std::vector<int64_t>> Runs::jobSweepIds(int64_t jobId) {
  std::lock_guard lock(mutex_);
  return guarded<std::vector<int64_t>>("jobSweepIds", [&]() -> Result<std::vector<int64_t>> {
    Statement query(db_, "SELECT id FROM sweeps WHERE job_id = ?1 ORDER BY id");
    query.bind(1, jobId);
    std::vector<int64_t> ids;
    while (query.step()) ids.push_back(query.getInt(0));
    return ids;
  });
}

}  // namespace tally::store

#include "store/store.hpp"

#include <charconv>
#include <cstdio>

#include "protocol.hpp"
#include "store/internal.hpp"
#include "store/migrations.hpp"

namespace tally::store {

namespace detail {
std::mutex& writeMutex() {
  static std::mutex mutex;
  return mutex;
}
Result<std::optional<int64_t>> checkPage(const Page& page) {
  if (page.limit < 1 || page.limit > 1000) {
    return makeError("limit: must be between 1 and 1000, got " + std::to_string(page.limit));
  }
  if (page.cursor.empty()) return std::optional<int64_t>();
  auto after = decodeCursor(page.cursor);
  if (!after) return makeError("cursor: not a cursor from a previous page");
  return after;
}

}  // namespace detail

const char* toString(JobStatus status) {
  switch (status) {
    case JobStatus::Queued: return protocol::kJobQueued;
    case JobStatus::Running: return protocol::kJobRunning;
    case JobStatus::Done: return protocol::kJobDone;
    case JobStatus::Failed: return protocol::kJobFailed;
    case JobStatus::Cancelled: return protocol::kJobCancelled;
  }
  return "unknown";
}

std::optional<JobStatus> parseJobStatus(std::string_view name) {
  for (JobStatus s : kJobStatuses) {
    if (name == toString(s)) return s;
  }
  return std::nullopt;
}

// Cursors are "r" + the last id in hex: opaque to clients, cheap to check.
std::string encodeCursor(int64_t lastId) {
  char text[24];
  std::snprintf(text, sizeof text, "r%llx", static_cast<unsigned long long>(lastId));
  return text;
}

std::optional<int64_t> decodeCursor(std::string_view cursor) {
  if (cursor.size() < 2 || cursor.size() > 17 || cursor[0] != 'r') return std::nullopt;
  int64_t id = 0;
  auto [end, ec] = std::from_chars(cursor.data() + 1, cursor.data() + cursor.size(), id, 16);
  if (ec != std::errc() || end != cursor.data() + cursor.size() || id <= 0) return std::nullopt;
  return id;
}

namespace {

Result<std::unique_ptr<Connection>> openSqliteStore(const std::string& path, const Store::Options& options) {
  std::unique_ptr<Connection> db;
  try {
    db = openSqlite(path, !options.readOnly, options.busyTimeoutMs);
  } catch (const std::exception& e) {
    setLastFault(faultOf(e));
    return makeError(e.what());
  }
  auto fail = [&](const std::string& message) -> Result<std::unique_ptr<Connection>> {
    return makeError("database '" + path + "': " + message);
  };
  // Refuse a newer schema before touching anything (not even the journal mode).
  auto version = schemaVersion(*db);
  if (!version) return fail(version.error());
  if (*version > latestSchemaVersion()) {
    return fail("schema version " + std::to_string(*version) + " is newer than this tallyd knows (" +
                std::to_string(latestSchemaVersion()) + "); use a newer tallyd or another database");
  }
  try {
    if (!options.readOnly) {
      // WAL: readers and the writer do not block each other. The mode persists
      // in the file, so readers need not set it.
      Statement mode(*db, "PRAGMA journal_mode = WAL");
      mode.step();
      std::string got = mode.getText(0);
      if (got != "wal" && got != "memory") return fail("cannot use WAL journal mode (got " + got + ")");
    }
    db->exec("PRAGMA synchronous = FULL");  // durable commits: 202 means stored
    db->exec("PRAGMA foreign_keys = ON");
    if (options.readOnly) db->exec("PRAGMA query_only = ON");
  } catch (const std::exception& e) {
    setLastFault(faultOf(e));
    return fail(e.what());
  }
  return db;
}

Result<std::unique_ptr<Connection>> openPostgresStore(const std::string& url, const Store::Options& options) {
  std::unique_ptr<Connection> db;
  try {
    db = openPostgres(url);
    // Lock waits end like SQLite's busy timeout; readers cannot write.
    db->exec("SET lock_timeout = " + std::to_string(options.busyTimeoutMs));
    if (options.readOnly) db->exec("SET default_transaction_read_only = on");
  } catch (const std::exception& e) {
    setLastFault(faultOf(e));
    return makeError(e.what());
  }
  return db;
}

}  // namespace

Result<std::unique_ptr<Store>> Store::open(const std::string& location, Options options) {
  setLastFault(Fault::kNone);
  const bool postgres = isPostgresUrl(location);
  auto db = postgres ? openPostgresStore(location, options) : openSqliteStore(location, options);
  if (!db) return makeError(db.error());
  const std::string name = postgres ? redactUrl(location) : location;
  auto migrated = options.readOnly ? requireCurrentSchema(**db) : [&] {
    detail::WriteLock lock(**db);
    return migrate(**db);
  }();
  if (!migrated) return makeError("database '" + name + "': " + migrated.error());
  return std::unique_ptr<Store>(new Store(std::move(*db), *migrated, location));
}

Store::Store(std::unique_ptr<Connection> db, int version, const std::string& location)
    : owner_(std::move(db)),
      shared_(owner_.get(), location),
      schemaVersion_(version),
      jobs_(shared_),
      hosts_(shared_),
      runs_(shared_),
      alerts_(shared_) {}

Store::~Store() = default;

Result<std::string> Store::integrityCheck() {
  std::lock_guard lock(shared_.mutex);
  return detail::guarded<std::string>("integrity_check", [&]() -> Result<std::string> {
    if (shared_.db->engine() == Engine::Postgres) {
      Statement ping(shared_.db, "SELECT 1");
      return ping.step() ? std::string("ok") : std::string("no answer");
    }
    Statement check(shared_.db, "PRAGMA integrity_check");
    std::string first = check.step() ? check.getText(0) : std::string("no answer");
    if (first != "ok") return first;
    Statement keys(shared_.db, "SELECT COUNT(*) FROM pragma_foreign_key_check");
    keys.step();
    if (int64_t n = keys.getInt(0)) return std::to_string(n) + " foreign key violations";
    return first;
  });
}

Result<std::string> Store::quickCheck() {
  std::lock_guard lock(shared_.mutex);
  return detail::guarded<std::string>("health check", [&]() -> Result<std::string> {
    if (shared_.db->engine() == Engine::Postgres) {
      Statement ping(shared_.db, "SELECT 1");
      return ping.step() ? std::string("ok") : std::string("no answer");
    }
    // Its first lines name the damage; "ok" alone when there is none.
    Statement check(shared_.db, "PRAGMA quick_check(3)");
    std::string lines;
    while (check.step()) lines += (lines.empty() ? "" : "\n") + check.getText(0);
    // One line ("*** in database main ***; Page 118: ..."), for logs and messages.
    for (size_t at = lines.find('\n'); at != std::string::npos; at = lines.find('\n', at)) {
      lines.replace(at, 1, "; ");
    }
    return lines.empty() ? std::string("no answer") : lines;
  });
}

Result<bool> Store::probeWrite() {
  std::lock_guard lock(shared_.mutex);
  return detail::guarded<bool>("write probe", [&]() -> Result<bool> {
    if (shared_.db->engine() == Engine::Postgres) {
      Statement ping(shared_.db, "SELECT 1");
      return ping.step();
    }
    // Rewrites the header's user_version with the value it holds: one page
    // written and committed, nothing changed.
    detail::WriteLock writing(*shared_.db);
    shared_.db->exec("PRAGMA user_version = " + std::to_string(schemaVersion_));
    return true;
  });
}

}  // namespace tally::store

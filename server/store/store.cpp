#include "store/store.hpp"

#include <sqlite3.h>

#include <charconv>
#include <cstdio>

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
    case JobStatus::Queued: return "queued";
    case JobStatus::Running: return "running";
    case JobStatus::Done: return "done";
    case JobStatus::Failed: return "failed";
    case JobStatus::Cancelled: return "cancelled";
  }
  return "unknown";
}

std::optional<JobStatus> parseJobStatus(std::string_view name) {
  for (JobStatus s :
       {JobStatus::Queued, JobStatus::Running, JobStatus::Done, JobStatus::Failed, JobStatus::Cancelled}) {
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

void pragma(sqlite3* db, const char* sql) { exec(db, sql); }

}  // namespace

Result<std::unique_ptr<Store>> Store::open(const std::string& path, Options options) {
  sqlite3* db = nullptr;
  int flags = SQLITE_OPEN_READWRITE | (options.readOnly ? 0 : SQLITE_OPEN_CREATE);
  int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  if (rc != SQLITE_OK) {
    std::string message =
        "opening database '" + path + "': " + (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
    sqlite3_close(db);
    return makeError(message);
  }
  auto fail = [&](const std::string& message) -> Result<std::unique_ptr<Store>> {
    sqlite3_close(db);
    return makeError("database '" + path + "': " + message);
  };
  sqlite3_extended_result_codes(db, 1);
  sqlite3_busy_timeout(db, options.busyTimeoutMs);
  // Refuse a newer schema before touching anything (not even the journal mode).
  auto version = store::schemaVersion(db);
  if (!version) return fail(version.error());
  if (*version > latestSchemaVersion()) {
    return fail("schema version " + std::to_string(*version) + " is newer than this tallyd knows (" +
                std::to_string(latestSchemaVersion()) + "); use a newer tallyd or another database");
  }
  try {
    if (!options.readOnly) {
      // WAL: readers and the writer do not block each other. The mode persists
      // in the file, so readers need not set it.
      Statement mode(db, "PRAGMA journal_mode = WAL");
      mode.step();
      std::string got = mode.getText(0);
      if (got != "wal" && got != "memory") return fail("cannot use WAL journal mode (got " + got + ")");
    }
    pragma(db, "PRAGMA synchronous = FULL");  // durable commits: 202 means stored
    pragma(db, "PRAGMA foreign_keys = ON");
    if (options.readOnly) pragma(db, "PRAGMA query_only = ON");
  } catch (const std::exception& e) {
    return fail(e.what());
  }
  auto migrated = options.readOnly ? requireCurrentSchema(db) : [&] {
    std::lock_guard lock(detail::writeMutex());
    return migrate(db);
  }();
  if (!migrated) return fail(migrated.error());
  return std::unique_ptr<Store>(new Store(db, *migrated));
}

Store::~Store() { sqlite3_close_v2(db_); }

Result<std::string> Store::integrityCheck() {
  std::lock_guard lock(mutex_);
  return detail::guarded<std::string>("integrity_check", [&]() -> Result<std::string> {
    Statement check(db_, "PRAGMA integrity_check");
    return check.step() ? check.getText(0) : std::string("no answer");
  });
}

}  // namespace tally::store

#include "store/migrations.hpp"

#include "store/fault.hpp"

#include <string>

namespace tally::store {
namespace {

// Any constant: the advisory lock that serialises PostgreSQL migrations.
constexpr const char* kMigrationLock = "SELECT pg_advisory_xact_lock(7371696)";

int readVersion(Connection& db) {
  if (db.engine() == Engine::Sqlite) {
    Statement query(db, "PRAGMA user_version");
    query.step();
    return static_cast<int>(query.getInt(0));
  }
  // A catalog read, not to_regclass(): a prepared to_regclass() is planned
  // once, and its answer kept, while another daemon creates the table.
  Statement exists(db,
                   "SELECT COUNT(*) FROM pg_class c JOIN pg_namespace n ON n.oid = c.relnamespace "
                   "WHERE c.relname = 'tally_schema_version' AND n.nspname = current_schema()");
  exists.step();
  if (!exists.getInt(0)) return 0;
  Statement query(db, "SELECT COALESCE(MAX(version), 0) FROM tally_schema_version");
  query.step();
  return static_cast<int>(query.getInt(0));
}

void writeVersion(Connection& db, int version) {
  if (db.engine() == Engine::Sqlite) {
    // PRAGMA takes no bound parameters; the value is the binary's own constant.
    db.exec("PRAGMA user_version = " + std::to_string(version));
    return;
  }
  db.exec("CREATE TABLE IF NOT EXISTS tally_schema_version (version INTEGER NOT NULL)");
  db.exec("DELETE FROM tally_schema_version");
  Statement insert(db, "INSERT INTO tally_schema_version (version) VALUES (?1)");
  insert.bind(1, version).run();
}

std::string tooNew(int found, int known) {
  return "database schema version " + std::to_string(found) + " is newer than this tallyd knows (" +
         std::to_string(known) + "); use a newer tallyd or another database";
}

}  // namespace

int latestSchemaVersion() {
  auto all = embeddedMigrations(Engine::Sqlite);
  return all.empty() ? 0 : all.back().version;
}

Result<int> schemaVersion(Connection& db) {
  try {
    return readVersion(db);
  } catch (const std::exception& e) {
    setLastFault(faultOf(e));
    return makeError(e.what());
  }
}

Result<int> migrate(Connection& db) { return migrate(db, embeddedMigrations(db.engine())); }

Result<int> migrate(Connection& db, std::span<const Migration> migrations) {
  int known = migrations.empty() ? 0 : migrations.back().version;
  try {
    int found = readVersion(db);
    if (found > known) return makeError(tooNew(found, known));
    for (const Migration& m : migrations) {
      if (m.version <= found) continue;
      Transaction tx(db, Transaction::Kind::Write);
      if (db.engine() == Engine::Postgres) db.exec(kMigrationLock);
      found = readVersion(db);  // another process may have migrated meanwhile
      if (found > known) return makeError(tooNew(found, known));
      if (m.version <= found) continue;
      if (m.version != found + 1) {
        return makeError("migration " + std::to_string(m.version) + " cannot follow schema version " +
                         std::to_string(found));
      }
      try {
        db.exec(m.sql);
        writeVersion(db, m.version);
      } catch (const std::exception& e) {
        return makeError("migration " + std::to_string(m.version) + "_" + std::string(m.name) +
                         " failed: " + e.what());
      }
      tx.commit();
      found = m.version;
    }
    return found;
  } catch (const std::exception& e) {
    setLastFault(faultOf(e));
    return makeError(std::string("migrating the database: ") + e.what());
  }
}

Result<int> requireCurrentSchema(Connection& db) {
  auto version = schemaVersion(db);
  if (!version) return version;
  int known = latestSchemaVersion();
  if (*version > known) return makeError(tooNew(*version, known));
  if (*version < known) {
    return makeError("database schema version " + std::to_string(*version) + " is older than " +
                     std::to_string(known) + "; open it once for writing to migrate it");
  }
  return *version;
}

}  // namespace tally::store

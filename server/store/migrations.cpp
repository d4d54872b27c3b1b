#include "store/migrations.hpp"

#include <string>

#include "store/sqlite.hpp"

namespace tally::store {
namespace {

int readVersion(sqlite3* db) {
  Statement query(db, "PRAGMA user_version");
  query.step();
  return static_cast<int>(query.getInt(0));
}

std::string tooNew(int found, int known) {
  return "database schema version " + std::to_string(found) + " is newer than this tallyd knows (" +
         std::to_string(known) + "); use a newer tallyd or another database";
}

}  // namespace

int latestSchemaVersion() {
  auto all = embeddedMigrations();
  return all.empty() ? 0 : all.back().version;
}

Result<int> schemaVersion(sqlite3* db) {
  try {
    return readVersion(db);
  } catch (const std::exception& e) {
    return makeError(e.what());
  }
}

Result<int> migrate(sqlite3* db, std::span<const Migration> migrations) {
  int known = migrations.empty() ? 0 : migrations.back().version;
  try {
    int found = readVersion(db);
    if (found > known) return makeError(tooNew(found, known));
    for (const Migration& m : migrations) {
      if (m.version <= found) continue;
      Transaction tx(db, Transaction::Kind::Write);
      found = readVersion(db);  // another process may have migrated meanwhile
      if (found > known) return makeError(tooNew(found, known));
      if (m.version <= found) continue;
      if (m.version != found + 1) {
        return makeError("migration " + std::to_string(m.version) + " cannot follow schema version " +
                         std::to_string(found));
      }
      try {
        exec(db, m.sql);
        // PRAGMA takes no bound parameters; the value is the binary's own constant.
        exec(db, "PRAGMA user_version = " + std::to_string(m.version));
      } catch (const std::exception& e) {
        return makeError("migration " + std::to_string(m.version) + "_" + std::string(m.name) +
                         " failed: " + e.what());
      }
      tx.commit();
      found = m.version;
    }
    return found;
  } catch (const std::exception& e) {
    return makeError(std::string("migrating the database: ") + e.what());
  }
}

Result<int> requireCurrentSchema(sqlite3* db) {
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

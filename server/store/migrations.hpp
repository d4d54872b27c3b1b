// Schema migrations: migrations/NNNN_name.sql, embedded at build time
// (embed_migrations.cmake), applied in order, each in its own transaction,
// tracked with PRAGMA user_version (= the number of the last one applied).
#pragma once

#include <sqlite3.h>

#include <span>
#include <string_view>

#include "common/result.hpp"

namespace tally::store {

struct Migration {
  int version;            // NNNN, from 1 without gaps
  std::string_view name;  // the file name's rest, without ".sql"
  std::string_view sql;
};

// Every migration this binary knows, in order (generated migrations_data.cpp).
std::span<const Migration> embeddedMigrations();
// The highest migration this binary knows: the schema version it reads and writes.
int latestSchemaVersion();

// PRAGMA user_version of an open database.
Result<int> schemaVersion(sqlite3* db);
// Applies the migrations newer than the database's user_version; refuses a
// database newer than latestSchemaVersion(). Safe against another process
// migrating at the same time (each step re-reads the version under the write
// lock). Returns the version now.
Result<int> migrate(sqlite3* db, std::span<const Migration> migrations = embeddedMigrations());
// For connections that must not migrate (readers): ok only when the database
// is exactly at latestSchemaVersion().
Result<int> requireCurrentSchema(sqlite3* db);

}  // namespace tally::store

// Schema migrations: migrations/NNNN_name.sql for SQLite and
// migrations/postgresql/NNNN_name.sql for PostgreSQL, embedded at build time
// (embed_migrations.cmake), applied in order, each in its own transaction.
// The version (the number of the last one applied) is PRAGMA user_version in
// SQLite and the one row of tally_schema_version in PostgreSQL.
#pragma once

#include <span>
#include <string_view>

#include "common/result.hpp"
#include "store/db.hpp"

namespace tally::store {

struct Migration {
  int version;            // NNNN, from 1 without gaps
  std::string_view name;  // the file name's rest, without ".sql"
  std::string_view sql;
};

// Every migration this binary knows for an engine, in order (generated migrations_data.cpp).
std::span<const Migration> embeddedMigrations(Engine engine = Engine::Sqlite);
// The highest migration this binary knows: the schema version it reads and writes.
int latestSchemaVersion();

// The schema version of an open database (0 for an empty one).
Result<int> schemaVersion(Connection& db);
// Applies the migrations newer than the database's version; refuses a
// database newer than latestSchemaVersion(). Safe against another process
// migrating at the same time (each step re-reads the version under the write
// lock: SQLite's, or a PostgreSQL advisory lock). Returns the version now.
Result<int> migrate(Connection& db, std::span<const Migration> migrations);
Result<int> migrate(Connection& db);  // the embedded ones of db's engine
// For connections that must not migrate (readers): ok only when the database
// is exactly at latestSchemaVersion().
Result<int> requireCurrentSchema(Connection& db);

}  // namespace tally::store

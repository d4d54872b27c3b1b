// Migrations: apply from empty, refuse newer databases, reopen as a no-op,
// each migration atomic.
#include "store/migrations.hpp"

#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

int userVersion(const std::string& path) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  auto version = schemaVersion(db);
  sqlite3_close(db);
  return version ? *version : -1;
}

void setUserVersion(const std::string& path, int version) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  std::string sql = "PRAGMA user_version = " + std::to_string(version);
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
}

TEST(Migrations, EmbeddedAreNumberedFromOneWithoutGaps) {
  auto all = embeddedMigrations();
  ASSERT_FALSE(all.empty());
  for (size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(all[i].version, static_cast<int>(i + 1));
    EXPECT_FALSE(all[i].name.empty());
    EXPECT_NE(all[i].sql.find("CREATE"), std::string_view::npos) << all[i].name;
  }
  EXPECT_EQ(all[0].name, "initial");
  EXPECT_EQ(latestSchemaVersion(), static_cast<int>(all.size()));
}

TEST(Migrations, ApplyFromEmpty) {
  TempDb db;
  {
    auto store = openStore(db.path());
    ASSERT_NE(store, nullptr);
    EXPECT_EQ(store->schemaVersion(), latestSchemaVersion());
    for (const char* table : {"devices", "scenes", "jobs", "runs", "run_resources", "samples", "passes",
                              "counters", "screenshots"}) {
      EXPECT_EQ(
          scalar(*store, std::string("SELECT COUNT(*) FROM sqlite_schema WHERE type = 'table' AND name = '") +
                             table + "'"),
          1)
          << table;
    }
    EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM pragma_journal_mode WHERE journal_mode = 'wal'"), 1);
    EXPECT_EQ(scalar(*store, "PRAGMA foreign_keys"), 1);
    EXPECT_EQ(scalar(*store, "PRAGMA synchronous"), 2);  // FULL
    EXPECT_EQ(scalar(*store, "PRAGMA busy_timeout"), 5000);
  }
  EXPECT_EQ(userVersion(db.path()), static_cast<int>(embeddedMigrations().size()));
}

TEST(Migrations, NewerDatabaseIsRefusedNamingBothVersions) {
  TempDb db;
  { ASSERT_NE(openStore(db.path()), nullptr); }
  int newer = latestSchemaVersion() + 1;
  setUserVersion(db.path(), newer);
  for (bool readOnly : {false, true}) {
    auto store = Store::open(db.path(), {.readOnly = readOnly});
    ASSERT_FALSE(store);
    EXPECT_NE(store.error().find("schema version " + std::to_string(newer)), std::string::npos)
        << store.error();
    EXPECT_NE(store.error().find("(" + std::to_string(latestSchemaVersion()) + ")"), std::string::npos)
        << store.error();
  }
  EXPECT_EQ(userVersion(db.path()), newer);  // untouched
}

TEST(Migrations, ReopenIsANoOp) {
  TempDb db;
  int64_t jobId = 0;
  {
    auto store = openStore(db.path());
    ASSERT_NE(store, nullptr);
    auto job = store->createJob({{"renderers", {"forward"}}}, "key-1");
    ASSERT_TRUE(job);
    jobId = job->job.id;
  }
  std::string schemaBefore, schemaAfter;
  auto schemaText = [](Store& store) {
    std::string text;
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(store.handle(), "SELECT sql FROM sqlite_schema WHERE sql IS NOT NULL ORDER BY name",
                       -1, &st, nullptr);
    while (sqlite3_step(st) == SQLITE_ROW) text += reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
    return text;
  };
  {
    auto store = openStore(db.path());
    ASSERT_NE(store, nullptr);
    schemaBefore = schemaText(*store);
  }
  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  schemaAfter = schemaText(*store);
  EXPECT_EQ(schemaBefore, schemaAfter);
  EXPECT_EQ(store->schemaVersion(), latestSchemaVersion());
  auto job = store->getJob(jobId);
  ASSERT_TRUE(job && job->has_value());
  EXPECT_EQ((*job)->idempotencyKey, "key-1");
}

TEST(Migrations, EachMigrationIsOneTransaction) {
  TempDb db;
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(db.path().c_str(), &raw), SQLITE_OK);
  const Migration good[] = {{1, "first", "CREATE TABLE a (x); INSERT INTO a VALUES (1);"}};
  const Migration withBad[] = {{1, "first", "CREATE TABLE a (x); INSERT INTO a VALUES (1);"},
                               {2, "second", "CREATE TABLE b (x); INSERT INTO nowhere VALUES (1);"}};
  auto first = migrate(raw, good);
  ASSERT_TRUE(first) << first.error();
  EXPECT_EQ(*first, 1);
  auto again = migrate(raw, good);  // no-op: the INSERT does not run twice
  ASSERT_TRUE(again);
  auto failed = migrate(raw, withBad);
  ASSERT_FALSE(failed);
  EXPECT_NE(failed.error().find("2_second"), std::string::npos) << failed.error();
  EXPECT_EQ(*schemaVersion(raw), 1);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(raw,
                     "SELECT (SELECT COUNT(*) FROM a), (SELECT COUNT(*) FROM sqlite_schema WHERE name = 'b')",
                     -1, &st, nullptr);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(st, 0), 1);  // migration 1 ran once
  EXPECT_EQ(sqlite3_column_int(st, 1), 0);  // migration 2's table was rolled back
  sqlite3_finalize(st);
  sqlite3_close(raw);
}

TEST(Migrations, ReaderNeedsAMigratedDatabase) {
  TempDb db;
  auto missing = Store::open(db.path(), {.readOnly = true});
  EXPECT_FALSE(missing);  // a reader never creates the file
  { ASSERT_NE(openStore(db.path()), nullptr); }
  auto reader = openStore(db.path(), {.readOnly = true});
  ASSERT_NE(reader, nullptr);
  auto job = reader->createJob({{"renderers", {"forward"}}});
  EXPECT_FALSE(job);  // query_only
}

}  // namespace
}  // namespace tally::store::testing

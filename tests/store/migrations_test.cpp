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
  auto postgres = embeddedMigrations(Engine::Postgres);
  ASSERT_FALSE(all.empty());
  ASSERT_EQ(postgres.size(), all.size());
  auto changesSchema = [](std::string_view sql) {
    return sql.find("CREATE") != std::string_view::npos || sql.find("ALTER") != std::string_view::npos;
  };
  for (size_t i = 0; i < all.size(); ++i) {
    EXPECT_EQ(all[i].version, static_cast<int>(i + 1));
    EXPECT_FALSE(all[i].name.empty());
    EXPECT_EQ(postgres[i].name, all[i].name);
    // Each one changes the schema of one engine or both (0012 only PostgreSQL's).
    EXPECT_TRUE(changesSchema(all[i].sql) || changesSchema(postgres[i].sql)) << all[i].name;
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
                              "counters", "screenshots", "sweeps"}) {
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
    auto job = store->jobs().create({{"renderers", {"forward"}}}, "key-1");
    ASSERT_TRUE(job);
    jobId = job->job.id;
  }
  std::string schemaBefore, schemaAfter;
  auto schemaText = [](Store& store) {
    std::string text;
    sqlite3_stmt* st = nullptr;
    sqlite3_prepare_v2(handle(store), "SELECT sql FROM sqlite_schema WHERE sql IS NOT NULL ORDER BY name",
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
  auto job = store->jobs().get(jobId);
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

// A database of the first release (schema 1) with a job, a run, a sample and
// its passes upgrades to the current schema: every row kept, the new run
// column NULL, and sweeps can be stored.
TEST(Migrations, VersionOneWithDataUpgradesKeepingEverything) {
  TempDb db;
  {
    sqlite3* raw = nullptr;
    ASSERT_EQ(sqlite3_open(db.path().c_str(), &raw), SQLITE_OK);
    auto first = migrate(raw, embeddedMigrations().first(1));
    ASSERT_TRUE(first) << first.error();
    ASSERT_EQ(*first, 1);
    const char* rows =
        "INSERT INTO devices (id, fingerprint, name, vendor, driver, api_version) "
        "VALUES (1, 'llvmpipe', 'llvmpipe', '0x10005', 'Mesa', '1.3');"
        "INSERT INTO scenes (id, name, params) VALUES (1, 'atrium', '{}');"
        "INSERT INTO jobs (id, status, spec, idempotency_key) VALUES (1, 'done', '{\"renderers\":[\"forward\"]}', 'k');"
        "INSERT INTO runs (id, job_id, device_id, renderer, scene_id, width, height, counting, lights) "
        "VALUES (1, 1, 1, 'forward', 1, 64, 36, 'exact', 4);"
        "INSERT INTO samples (id, run_id, camera_index, camera, frame_ms, bytes) VALUES (1, 1, 0, '{}', 1.5, 96);"
        "INSERT INTO passes (id, sample_id, position, name, gpu_ms) VALUES (1, 1, 0, 'opaque', 1.25);"
        "INSERT INTO counters (pass_id, position, resource, access, count, bytes, source) "
        "VALUES (1, 0, 'depth', 'write', 24, 96, 'counter');";
    ASSERT_EQ(sqlite3_exec(raw, rows, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(raw);
    sqlite3_close(raw);
  }
  ASSERT_EQ(userVersion(db.path()), 1);

  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  EXPECT_EQ(store->schemaVersion(), latestSchemaVersion());
  EXPECT_GE(latestSchemaVersion(), 2);
  for (const char* table : {"devices", "scenes", "jobs", "runs", "samples", "passes", "counters"}) {
    EXPECT_EQ(scalar(*store, std::string("SELECT COUNT(*) FROM ") + table), 1) << table;
  }
  auto job = store->jobs().get(1);
  ASSERT_TRUE(job && job->has_value());
  EXPECT_EQ((*job)->status, JobStatus::Done);
  EXPECT_EQ((*job)->idempotencyKey, "k");
  auto run = store->runs().get(1);
  ASSERT_TRUE(run && run->has_value()) << (run ? "" : run.error());
  EXPECT_EQ((*run)->row.renderer, "forward");
  EXPECT_EQ((*run)->row.sampleCount, 1);
  ASSERT_TRUE((*run)->row.meanBytes);
  EXPECT_EQ(*(*run)->row.meanBytes, 96);
  EXPECT_TRUE((*run)->counterHeadroom.is_null());  // not measured back then
  auto passes = store->runs().passes(1);
  ASSERT_TRUE(passes);
  ASSERT_EQ(passes->size(), 1u);
  EXPECT_EQ((*passes)[0].counters.size(), 1u);
  EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM sweeps"), 0);
  // The new column's check holds for new rows.
  EXPECT_NE(sqlite3_exec(handle(*store), "UPDATE runs SET counter_headroom = 'not json' WHERE id = 1", nullptr,
                         nullptr, nullptr),
            SQLITE_OK);
  EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM pragma_foreign_key_check"), 0);
  auto integrity = store->integrityCheck();
  ASSERT_TRUE(integrity);
  EXPECT_EQ(*integrity, "ok");
}

// A database of schema 2 with a run (its counter headroom), a sample with an
// image error, and a sweep upgrades to 3: every row and value kept, the run's
// variant backfilled with its renderer, options and extras {} and no
// variant_error; the new columns' checks hold.
TEST(Migrations, VersionTwoWithDataUpgradesToVariantsKeepingEverything) {
  TempDb db;
  {
    sqlite3* raw = nullptr;
    ASSERT_EQ(sqlite3_open(db.path().c_str(), &raw), SQLITE_OK);
    auto second = migrate(raw, embeddedMigrations().first(2));
    ASSERT_TRUE(second) << second.error();
    ASSERT_EQ(*second, 2);
    const char* rows =
        "INSERT INTO devices (id, fingerprint, name, vendor, driver, api_version) "
        "VALUES (1, 'llvmpipe', 'llvmpipe', '0x10005', 'Mesa', '1.3');"
        "INSERT INTO scenes (id, name, params) VALUES (1, 'atrium', '{}');"
        "INSERT INTO jobs (id, status, spec, idempotency_key) VALUES (1, 'done', '{\"renderers\":[\"deferred\"]}', 'k');"
        "INSERT INTO runs (id, job_id, device_id, renderer, scene_id, width, height, counting, lights, "
        "counter_headroom) VALUES (1, 1, 1, 'deferred', 1, 64, 36, 'exact', 4, '{\"max\":7}');"
        "INSERT INTO samples (id, run_id, camera_index, camera, frame_ms, bytes, image_against, image_identical, "
        "psnr, max_abs, mean_abs) VALUES (1, 1, 0, '{}', 1.5, 96, 'forward', 0, 41.5, 3, 0.25);"
        "INSERT INTO passes (id, sample_id, position, name, gpu_ms) VALUES (1, 1, 0, 'gbuffer', 1.25);"
        "INSERT INTO counters (pass_id, position, resource, access, count, bytes, source) "
        "VALUES (1, 0, 'depth', 'write', 24, 96, 'counter');"
        "INSERT INTO sweeps (id, job_id, device_id, name, parameters, threshold, point_count, result) "
        "VALUES (1, 1, 1, 'depth', '{}', '{}', 0, '{}');";
    ASSERT_EQ(sqlite3_exec(raw, rows, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(raw);
    sqlite3_close(raw);
  }
  ASSERT_EQ(userVersion(db.path()), 2);

  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  EXPECT_GE(store->schemaVersion(), 3);
  for (const char* table : {"devices", "scenes", "jobs", "runs", "samples", "passes", "counters", "sweeps"}) {
    EXPECT_EQ(scalar(*store, std::string("SELECT COUNT(*) FROM ") + table), 1) << table;
  }
  auto run = store->runs().get(1);
  ASSERT_TRUE(run && run->has_value()) << (run ? "" : run.error());
  EXPECT_EQ((*run)->row.renderer, "deferred");
  EXPECT_EQ((*run)->row.variant, "deferred");
  EXPECT_EQ((*run)->row.options, nlohmann::json::object());
  EXPECT_EQ((*run)->counterHeadroom, nlohmann::json({{"max", 7}}));
  EXPECT_EQ((*run)->row.imageCompared, 1);
  auto samples = store->runs().samples(1);
  ASSERT_TRUE(samples) << samples.error();
  ASSERT_EQ(samples->size(), 1u);
  const SampleRow& sample = (*samples)[0];
  EXPECT_EQ(sample.bytes, 96);
  ASSERT_TRUE(sample.imageError);
  EXPECT_EQ(sample.imageError->against, "forward");
  ASSERT_TRUE(sample.imageError->psnr);
  EXPECT_EQ(*sample.imageError->psnr, 41.5);
  EXPECT_EQ(sample.imageError->maxAbs, 3);
  EXPECT_EQ(sample.extras, nlohmann::json::object());
  EXPECT_FALSE(sample.variantError);
  RunFilter byVariant;
  byVariant.variant = "deferred";
  auto page = store->runs().list(byVariant, Page{});
  ASSERT_TRUE(page) << page.error();
  EXPECT_EQ(page->runs.size(), 1u);
  for (const char* bad : {"UPDATE runs SET options = 'not json' WHERE id = 1",
                          "UPDATE samples SET extras = 'not json' WHERE id = 1"}) {
    EXPECT_NE(sqlite3_exec(handle(*store), bad, nullptr, nullptr, nullptr), SQLITE_OK) << bad;
  }
  EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM pragma_foreign_key_check"), 0);
  auto integrity = store->integrityCheck();
  ASSERT_TRUE(integrity);
  EXPECT_EQ(*integrity, "ok");
}

// A database of schema 5 (runs with their build) holding a run, a sample,
// a pass and a line upgrades to 6 (0006_footprint): every row and value kept,
// the new footprint columns NULL, so the run reads as one without footprint;
// the block size's check holds for new values.
TEST(Migrations, VersionFiveWithDataUpgradesToFootprintKeepingEverything) {
  TempDb db;
  {
    sqlite3* raw = nullptr;
    ASSERT_EQ(sqlite3_open(db.path().c_str(), &raw), SQLITE_OK);
    auto fifth = migrate(raw, embeddedMigrations().first(5));
    ASSERT_TRUE(fifth) << fifth.error();
    ASSERT_EQ(*fifth, 5);
    const char* rows =
        "INSERT INTO devices (id, fingerprint, name, vendor, driver, api_version) "
        "VALUES (1, 'llvmpipe', 'llvmpipe', '0x10005', 'Mesa', '1.3');"
        "INSERT INTO scenes (id, name, params) VALUES (1, 'atrium', '{}');"
        "INSERT INTO jobs (id, status, spec) VALUES (1, 'done', '{\"renderers\":[\"deferred\"]}');"
        "INSERT INTO runs (id, job_id, device_id, renderer, scene_id, width, height, counting, lights, variant, "
        "tally_version, tally_commit) VALUES (1, 1, 1, 'deferred', 1, 64, 36, 'accumulate', 4, 'deferred', "
        "'0.1.0', '7eabc68a1b2c');"
        "INSERT INTO samples (id, run_id, camera_index, camera, frame_ms, bytes) VALUES (1, 1, 0, '{}', 1.5, 96);"
        "INSERT INTO passes (id, sample_id, position, name, gpu_ms) VALUES (1, 1, 0, 'gbuffer', 1.25);"
        "INSERT INTO counters (pass_id, position, resource, access, count, bytes, source) "
        "VALUES (1, 0, 'depth', 'write', 24, 96, 'counter');";
    ASSERT_EQ(sqlite3_exec(raw, rows, nullptr, nullptr, nullptr), SQLITE_OK) << sqlite3_errmsg(raw);
    sqlite3_close(raw);
  }
  ASSERT_EQ(userVersion(db.path()), 5);

  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  EXPECT_GE(store->schemaVersion(), 6);
  for (const char* table : {"runs", "samples", "passes", "counters"}) {
    EXPECT_EQ(scalar(*store, std::string("SELECT COUNT(*) FROM ") + table), 1) << table;
  }
  for (const char* column : {"runs.footprint_block_bytes", "counters.footprint_bytes", "samples.footprint_bytes",
                             "samples.footprint_requested_bytes"}) {
    std::string name(column);
    std::string table = name.substr(0, name.find('.')), col = name.substr(name.find('.') + 1);
    EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM pragma_table_info('" + table + "') WHERE name = '" + col + "'"), 1)
        << column;
    EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM " + table + " WHERE " + col + " IS NULL"), 1) << column;
  }
  auto run = store->runs().get(1);
  ASSERT_TRUE(run && run->has_value()) << (run ? "" : run.error());
  EXPECT_EQ((*run)->row.tallyVersion, "0.1.0");  // 0005's columns kept
  EXPECT_EQ((*run)->row.counting, "accumulate");
  EXPECT_FALSE((*run)->row.footprintBlockBytes);
  EXPECT_FALSE((*run)->row.meanFootprintBytes);
  ASSERT_TRUE((*run)->row.meanBytes);
  EXPECT_EQ(*(*run)->row.meanBytes, 96);
  auto samples = store->runs().samples(1);
  ASSERT_TRUE(samples) << samples.error();
  ASSERT_EQ(samples->size(), 1u);
  EXPECT_EQ((*samples)[0].bytes, 96);
  EXPECT_FALSE((*samples)[0].footprintBytes);
  auto sample = store->runs().sample(1);
  ASSERT_TRUE(sample && sample->has_value());
  ASSERT_EQ((*sample)->passes.size(), 1u);
  ASSERT_EQ((*sample)->passes[0].counters.size(), 1u);
  EXPECT_EQ((*sample)->passes[0].counters[0].bytes, 96);
  EXPECT_FALSE((*sample)->passes[0].counters[0].footprintBytes);
  // The new columns' checks: a block size of 32, 64 or 128 only, no negative footprint.
  EXPECT_EQ(sqlite3_exec(handle(*store), "UPDATE runs SET footprint_block_bytes = 64 WHERE id = 1", nullptr,
                         nullptr, nullptr),
            SQLITE_OK);
  for (const char* bad : {"UPDATE runs SET footprint_block_bytes = 48 WHERE id = 1",
                          "UPDATE counters SET footprint_bytes = -1"}) {
    EXPECT_NE(sqlite3_exec(handle(*store), bad, nullptr, nullptr, nullptr), SQLITE_OK) << bad;
  }
  EXPECT_EQ(scalar(*store, "SELECT footprint_block_bytes FROM runs WHERE id = 1"), 64);
  auto integrity = store->integrityCheck();
  ASSERT_TRUE(integrity);
  EXPECT_EQ(*integrity, "ok");
}

TEST(Migrations, ReaderNeedsAMigratedDatabase) {
  TempDb db;
  auto missing = Store::open(db.path(), {.readOnly = true});
  EXPECT_FALSE(missing);  // a reader never creates the file
  { ASSERT_NE(openStore(db.path()), nullptr); }
  auto reader = openStore(db.path(), {.readOnly = true});
  ASSERT_NE(reader, nullptr);
  auto job = reader->jobs().create({{"renderers", {"forward"}}});
  EXPECT_FALSE(job);  // query_only
}

}  // namespace
}  // namespace tally::store::testing

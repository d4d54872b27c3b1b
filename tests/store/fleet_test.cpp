// The fleet's queue in the store, on either engine (store.* on SQLite,
// store.postgresql on PostgreSQL): device requirements and claims by device,
// leases (renewed, expired, requeued, failed with their reasons), fenced
// ingest, hosts; and on PostgreSQL, that both engines' migrations build the
// same schema.
#include <set>
#include <thread>

#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

json nvidia() {
  json d = device("NVIDIA H100 80GB HBM3");
  d["vendorID"] = "0x10DE";
  d["features"]["fragmentBarycentric"] = true;
  return d;
}

TEST(DeviceRequirements, ParseAndMatch) {
  auto none = parseDeviceRequirement({{"renderers", {"forward"}}});
  ASSERT_TRUE(none);
  EXPECT_FALSE(*none);
  auto byName = parseDeviceRequirement({{"device", "h100"}});
  ASSERT_TRUE(byName && *byName);
  EXPECT_EQ(deviceMismatch(**byName, nvidia()), "");
  EXPECT_NE(deviceMismatch(**byName, device()).find("does not contain 'h100'"), std::string::npos);
  auto full = deviceRequirementFromJson({{"vendor", "nvidia"}, {"features", {"fragmentBarycentric"}}});
  ASSERT_TRUE(full) << full.error();
  EXPECT_EQ(deviceMismatch(*full, nvidia()), "");
  EXPECT_NE(deviceMismatch(*full, device()).find("vendor Mesa (0x10005) is not nvidia"), std::string::npos)
      << deviceMismatch(*full, device());
  auto byId = deviceRequirementFromJson({{"vendor", "0x10de"}, {"features", {"int64Atomics"}}});
  ASSERT_TRUE(byId);
  EXPECT_EQ(deviceMismatch(*byId, nvidia()), "");
  auto feature = deviceRequirementFromJson({{"features", {"fragmentBarycentric"}}});
  EXPECT_EQ(deviceMismatch(*feature, device()), "feature fragmentBarycentric is missing");
  EXPECT_EQ(deviceMismatch(*feature, nullptr), "no device known");
  // Bad requirements name the field.
  for (auto [bad, field] : std::vector<std::pair<json, std::string>>{{json(3), "device:"},
                                                                      {json(""), "device:"},
                                                                      {{{"name", 1}}, "device.name"},
                                                                      {{{"features", "x"}}, "device.features"},
                                                                      {{{"features", {2}}}, "device.features"},
                                                                      {{{"colour", "red"}}, "device.colour"},
                                                                      {json::object(), "device:"}}) {
    auto r = deviceRequirementFromJson(bad);
    ASSERT_FALSE(r) << bad.dump();
    EXPECT_EQ(r.error().rfind(field, 0), 0u) << r.error();
  }
}

class Fleet : public StoreTest {
 protected:
  HostInfo host(const std::string& name, json dev) {
    HostInfo h;
    h.name = name;
    h.instance = name + "-1";
    h.role = "worker";
    h.device = std::move(dev);
    h.tallyVersion = "0.1.0";
    h.tallyCommit = "abc";
    return h;
  }
  Claimer claimer(const std::string& hostName, json dev, int64_t leaseMs = 60000) {
    Claimer c;
    c.host = hostName;
    c.device = std::move(dev);
    c.leaseMs = leaseMs;
    return c;
  }
  int64_t job(const json& device = nullptr) {
    json spec = {{"renderers", {"forward"}}};
    if (!device.is_null()) spec["device"] = device;
    auto created = store_->jobs().create(spec, std::nullopt, 2);
    EXPECT_TRUE(created) << created.error();
    return created ? created->job.id : 0;
  }
};

TEST_F(Fleet, ClaimsOnlyWhatTheDeviceMeets) {
  int64_t forNvidia = job("H100");
  int64_t forAnyone = job();
  int64_t forBarycentrics = job({{"features", {"fragmentBarycentric"}}});
  // The CPU device skips the NVIDIA job and takes the next one it can run.
  auto cpu = store_->jobs().claim(claimer("cpu-box", device()));
  ASSERT_TRUE(cpu && *cpu) << (cpu ? "none" : cpu.error());
  EXPECT_EQ((*cpu)->id, forAnyone);
  EXPECT_EQ((*cpu)->host, "cpu-box");
  EXPECT_EQ((*cpu)->attempts, 1);
  EXPECT_TRUE((*cpu)->leaseExpiresMs);
  auto nothing = store_->jobs().claim(claimer("cpu-box", device()));
  ASSERT_TRUE(nothing);
  EXPECT_FALSE(*nothing) << "took job " << (*nothing)->id;
  // A worker with no device known takes only jobs without a requirement.
  auto blind = store_->jobs().claim(claimer("blind", nullptr));
  ASSERT_TRUE(blind);
  EXPECT_FALSE(*blind);
  auto gpu = store_->jobs().claim(claimer("gpu-box", nvidia()));
  ASSERT_TRUE(gpu && *gpu);
  EXPECT_EQ((*gpu)->id, forNvidia);
  EXPECT_EQ((*gpu)->deviceRequirement, (json{{"name", "H100"}}));
  auto second = store_->jobs().claim(claimer("gpu-box", nvidia()));
  ASSERT_TRUE(second && *second);
  EXPECT_EQ((*second)->id, forBarycentrics);
  // A bad requirement is refused at creation, naming the field.
  auto bad = store_->jobs().create({{"renderers", {"forward"}}, {"device", {{"vendor", 7}}}});
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("device.vendor"), std::string::npos) << bad.error();
}

TEST_F(Fleet, ExpiredLeasesAreRequeuedThenFailedWithTheirReasons) {
  int64_t id = job();  // max_attempts 2
  auto first = store_->jobs().claim(claimer("a", device(), /*leaseMs=*/1));
  ASSERT_TRUE(first && *first);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  auto reaped = store_->jobs().requeueExpired();
  ASSERT_TRUE(reaped) << reaped.error();
  EXPECT_EQ(reaped->requeued, std::vector<int64_t>{id});
  auto queued = **store_->jobs().get(id);
  EXPECT_EQ(queued.status, JobStatus::Queued);
  ASSERT_EQ(queued.attemptErrors.size(), 1u);
  EXPECT_NE(queued.attemptErrors[0].get<std::string>().find("attempt 1 on a: lease expired"), std::string::npos)
      << queued.attemptErrors.dump();
  // The first holder's lease no longer holds: it can neither renew, nor store, nor finish.
  Lease stale{id, 1, "a"};
  EXPECT_FALSE(*store_->jobs().renewLease(stale, 60000));
  Capture c = realisticCapture();
  auto late = store_->runs().ingestCapture(stale, c.result, c.screenshots);
  ASSERT_FALSE(late);
  EXPECT_NE(late.error().find("is no longer held by a"), std::string::npos) << late.error();
  EXPECT_FALSE(*store_->jobs().finish(stale, JobStatus::Done));
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs"), 0);

  auto second = store_->jobs().claim(claimer("b", device(), 1));
  ASSERT_TRUE(second && *second);
  EXPECT_EQ((*second)->attempts, 2);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  reaped = store_->jobs().requeueExpired();
  ASSERT_TRUE(reaped);
  EXPECT_EQ(reaped->failed, std::vector<int64_t>{id});
  auto failed = **store_->jobs().get(id);
  EXPECT_EQ(failed.status, JobStatus::Failed);
  ASSERT_TRUE(failed.error);
  EXPECT_NE(failed.error->find("failed after 2 attempts"), std::string::npos) << *failed.error;
  EXPECT_NE(failed.error->find("attempt 1 on a"), std::string::npos) << *failed.error;
  EXPECT_NE(failed.error->find("attempt 2 on b"), std::string::npos) << *failed.error;
}

TEST_F(Fleet, RenewedLeasesHoldAndIngestFinishesOnce) {
  ASSERT_TRUE(store_->hosts().join(host("a", device()), 30000));
  int64_t id = job();
  auto claimed = store_->jobs().claim(claimer("a", device(), 200));
  ASSERT_TRUE(claimed && *claimed);
  Lease lease{id, 1, "a"};
  // Renewed past the first lease's end (200 ms), each renewal for 10 s from
  // the database's now: a busy machine may stretch the sleeps, which only
  // takes the renewals further past the first end, while a renewal is never
  // seconds from the reaping that follows it.
  int64_t expires = *(**store_->jobs().get(id)).leaseExpiresMs;
  for (int i = 0; i < 4; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    ASSERT_TRUE(*store_->jobs().renewLease(lease, 10000));
    auto reaped = store_->jobs().requeueExpired();
    ASSERT_TRUE(reaped);
    EXPECT_TRUE(reaped->requeued.empty() && reaped->failed.empty());
    int64_t renewed = *(**store_->jobs().get(id)).leaseExpiresMs;
    EXPECT_GT(renewed, expires) << "renewal " << i << " did not move the lease's end";
    expires = renewed;
  }
  auto hosts = *store_->hosts().list(30000);
  ASSERT_EQ(hosts.size(), 1u);
  EXPECT_EQ(hosts[0].currentJob, id);
  Capture c = realisticCapture();
  auto stored = store_->runs().ingestCapture(lease, c.result, c.screenshots);
  ASSERT_TRUE(stored) << stored.error();
  EXPECT_EQ(*stored, 2);
  auto done = **store_->jobs().get(id);
  EXPECT_EQ(done.status, JobStatus::Done);
  EXPECT_FALSE(done.leaseExpiresMs);
  // Once done, the same lease stores nothing more.
  EXPECT_FALSE(store_->runs().ingestCapture(lease, c.result, c.screenshots));
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs"), 2);
  RunFilter byHost;
  byHost.host = "a";
  EXPECT_EQ(store_->runs().list(byHost, {})->runs.size(), 2u);
  EXPECT_EQ(store_->runs().list(byHost, {})->runs[0].host, "a");
  byHost.host = "b";
  EXPECT_TRUE(store_->runs().list(byHost, {})->runs.empty());
  hosts = *store_->hosts().list(30000);
  EXPECT_EQ(hosts[0].jobsDone, 1);
  EXPECT_FALSE(hosts[0].currentJob);
}

TEST_F(Fleet, CancellingEndsTheLease) {
  int64_t id = job();
  ASSERT_TRUE(*store_->jobs().claim(claimer("a", device())));
  ASSERT_TRUE(store_->jobs().cancel(id));
  Lease lease{id, 1, "a"};
  EXPECT_FALSE(*store_->jobs().renewLease(lease, 60000));  // the worker's next heartbeat stops the capture
  EXPECT_FALSE(*store_->jobs().finish(lease, JobStatus::Failed, "killed"));
  EXPECT_EQ((*store_->jobs().get(id))->status, JobStatus::Cancelled);
}

TEST_F(Fleet, HostsRegisterOncePerLiveName) {
  HostInfo a = host("gpu-a", nvidia());
  ASSERT_TRUE(store_->hosts().join(a, 30000));
  HostInfo intruder = a;
  intruder.instance = "other";
  auto refused = store_->hosts().join(intruder, 30000);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().find("in use by a live daemon"), std::string::npos) << refused.error();
  // Unless the holder is known to be gone (a restart after a crash).
  auto takeOver =
      store_->hosts().join(intruder, 30000, [&](const std::string& i) { return i == a.instance; });
  ASSERT_TRUE(takeOver) << takeOver.error();
  EXPECT_FALSE(
      *store_->hosts().heartbeat("gpu-a", a.instance, std::nullopt));  // the old instance lost its name
  EXPECT_TRUE(*store_->hosts().heartbeat("gpu-a", "other", 7));
  ASSERT_TRUE(store_->hosts().join(host("cpu-b", device()), 30000));
  auto hosts = *store_->hosts().list(30000);
  ASSERT_EQ(hosts.size(), 2u);
  EXPECT_EQ(hosts[0].info.name, "cpu-b");
  EXPECT_EQ(hosts[1].info.name, "gpu-a");
  EXPECT_EQ(hosts[1].currentJob, 7);
  EXPECT_TRUE(hosts[1].alive);
  EXPECT_EQ(hosts[1].info.device["name"], "NVIDIA H100 80GB HBM3");
  EXPECT_EQ(hosts[1].lastHeartbeat.size(), 24u) << hosts[1].lastHeartbeat;  // 2026-11-25T09:00:00.000Z
  // A stale limit of 0 ms: nobody is alive.
  auto stale = store_->hosts().list(0);  // kept: the loop's range lives in it
  for (const auto& h : *stale) EXPECT_FALSE(h.alive) << h.info.name;
  HostInfo badRole = host("x", nullptr);
  badRole.role = "api";
  EXPECT_FALSE(store_->hosts().join(badRole, 30000));
}

TEST_F(Fleet, ManyClaimersOnManyConnectionsTakeEachJobOnce) {
  constexpr int kJobs = 60;
  for (int i = 0; i < kJobs; ++i) job(i % 3 == 0 ? json("H100") : json(nullptr));
  std::vector<std::vector<int64_t>> claimed(6);
  std::vector<std::thread> workers;
  for (size_t w = 0; w < claimed.size(); ++w) {
    workers.emplace_back([&, w] {
      auto store = Store::open(db_.path());
      ASSERT_TRUE(store) << store.error();
      json dev = w % 2 ? nvidia() : device();
      std::string name = "w" + std::to_string(w);
      while (true) {
        auto got = (*store)->jobs().claim(claimer(name, dev));
        ASSERT_TRUE(got) << got.error();
        if (!*got) break;
        claimed[w].push_back((*got)->id);
        Capture c = realisticCapture(static_cast<int>((*got)->id));
        auto stored = (*store)->runs().ingestCapture(Lease{(*got)->id, 1, name}, c.result, c.screenshots);
        ASSERT_TRUE(stored) << stored.error();
      }
    });
  }
  for (auto& t : workers) t.join();
  std::set<int64_t> all;
  size_t total = 0;
  for (const auto& ids : claimed) {
    all.insert(ids.begin(), ids.end());
    total += ids.size();
  }
  EXPECT_EQ(total, static_cast<size_t>(kJobs));
  EXPECT_EQ(all.size(), static_cast<size_t>(kJobs));
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM jobs WHERE status = 'done' AND attempts = 1"), kJobs);
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM runs"), 2 * kJobs);
  // The H100 jobs went only to the NVIDIA claimers (odd ones).
  EXPECT_EQ(scalar(*store_, "SELECT COUNT(*) FROM jobs WHERE device_requirement IS NOT NULL AND host NOT IN "
                            "('w1', 'w3', 'w5')"),
            0);
}

// Both engines' migrations build the same tables, columns (in order, with
// nullability and a type of the same kind) and indexes. Runs in the
// PostgreSQL pass, where both engines are at hand.
TEST(Engines, MigrationsBuildTheSameSchema) {
  if (!postgresServer()) GTEST_SKIP() << "runs in store.postgresql (TALLY_TEST_STORE=postgres)";
  TempDb pgDb;
  auto pg = openStore(pgDb.path());
  ASSERT_NE(pg, nullptr);
  std::string file = (std::filesystem::temp_directory_path() / ("tally_engines_" + std::to_string(::getpid()) + ".db")).string();
  std::filesystem::remove(file);
  auto lite = openStore(file);
  ASSERT_NE(lite, nullptr);
  EXPECT_EQ(lite->schemaVersion(), pg->schemaVersion());
  // PostgreSQL arrays come as their element type's name after "_" (udt_name).
  std::function<std::string(std::string)> kind = [&kind](std::string type) {
    for (auto& c : type) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (type.rfind("_", 0) == 0) return kind(type.substr(1)) + "[]";
    if (type.find("int") != std::string::npos) return std::string("integer");
    if (type.find("real") != std::string::npos || type.find("double") != std::string::npos ||
        type.find("float") != std::string::npos) {
      return std::string("real");
    }
    if (type.find("blob") != std::string::npos || type.find("bytea") != std::string::npos) return std::string("blob");
    return std::string("text");
  };
  std::map<std::string, std::vector<std::string>> sqliteColumns, pgColumns;
  {
    Statement tables(lite->connection(),
                     "SELECT name FROM sqlite_schema WHERE type = 'table' AND name NOT LIKE 'sqlite_%' ORDER BY name");
    std::vector<std::string> names;
    while (tables.step()) names.push_back(tables.getText(0));
    for (const auto& t : names) {
      Statement columns(lite->connection(), "SELECT name, type, \"notnull\" OR pk FROM pragma_table_info(?1) ORDER BY cid");
      columns.bind(1, t);
      while (columns.step()) {
        sqliteColumns[t].push_back(columns.getText(0) + " " + kind(columns.getText(1)) +
                                   (columns.getInt(2) ? " not null" : ""));
      }
    }
  }
  {
    Statement columns(pg->connection(),
                      "SELECT table_name, column_name, CASE data_type WHEN 'ARRAY' THEN udt_name ELSE data_type END, "
                      "is_nullable FROM information_schema.columns "
                      "WHERE table_schema = current_schema() AND table_name <> 'tally_schema_version' "
                      "ORDER BY table_name, ordinal_position");
    while (columns.step()) {
      pgColumns[columns.getText(0)].push_back(columns.getText(1) + " " + kind(columns.getText(2)) +
                                              (columns.getText(3) == "NO" ? " not null" : ""));
    }
  }
  // The one planned difference (migration 0012): on PostgreSQL a pass's
  // counters are arrays on its row, and counters is a view with the table's
  // columns but id (a view's columns all read as nullable).
  std::vector<std::string> arrays;
  for (auto it = pgColumns["passes"].begin(); it != pgColumns["passes"].end();) {
    if (it->rfind("counter_", 0) == 0) {
      arrays.push_back(*it);
      it = pgColumns["passes"].erase(it);
    } else {
      ++it;
    }
  }
  EXPECT_EQ(arrays, (std::vector<std::string>{
                        "counter_resources text[] not null", "counter_kinds text[] not null",
                        "counter_formats text[] not null", "counter_accesses text[] not null",
                        "counter_counts real[] not null", "counter_bytes real[] not null",
                        "counter_spreads text[] not null", "counter_sources text[] not null",
                        "counter_footprints real[] not null"}));
  {
    Statement view(pg->connection(), "SELECT table_type FROM information_schema.tables WHERE table_name = 'counters'");
    ASSERT_TRUE(view.step());
    EXPECT_EQ(view.getText(0), "VIEW");
  }
  std::vector<std::string> tableCounters;
  for (std::string column : sqliteColumns["counters"]) {
    if (column.rfind("id ", 0) == 0) continue;
    if (auto at = column.find(" not null"); at != std::string::npos) column.erase(at);
    tableCounters.push_back(column);
  }
  EXPECT_EQ(pgColumns["counters"], tableCounters);
  EXPECT_EQ(tableCounters.size(), 11u);
  sqliteColumns.erase("counters");
  pgColumns.erase("counters");
  EXPECT_EQ(sqliteColumns, pgColumns);
  EXPECT_GE(sqliteColumns.size(), 11u);
  std::set<std::string> sqliteIndexes, pgIndexes;
  {
    Statement indexes(lite->connection(),
                      "SELECT name FROM sqlite_schema WHERE type = 'index' AND sql IS NOT NULL ORDER BY name");
    while (indexes.step()) sqliteIndexes.insert(indexes.getText(0));
    Statement pgIdx(pg->connection(),
                    "SELECT indexname FROM pg_indexes WHERE schemaname = current_schema() AND indexname NOT LIKE "
                    "'%_pkey' AND indexname NOT LIKE '%_key' ORDER BY indexname");
    while (pgIdx.step()) pgIndexes.insert(pgIdx.getText(0));
  }
  EXPECT_EQ(sqliteIndexes, pgIndexes);
  lite.reset();
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(file + suffix);
}

// The PostgreSQL statement: every type through a bind and back, named and
// numbered parameters, errors with the SQLSTATE, rollback by default.
// A young PostgreSQL database grown by ingests faster than autovacuum looks
// at it gets its statistics from the store (Runs::keepStatisticsCurrent,
// StatisticsKeeper): no analyse after a small result, one
// (pg_stat_user_tables.last_analyze, which autovacuum's own analyses leave
// alone) once 5,000 samples are stored, run beside the ingests and waited
// for here.
TEST(Engines, IngestsKeepPostgresStatisticsCurrent) {
  if (!postgresServer()) GTEST_SKIP() << "runs in store.postgresql (TALLY_TEST_STORE=postgres)";
  TempDb db;
  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  auto analysed = [&] {
    Statement s(store->connection(), "SELECT last_analyze IS NOT NULL FROM pg_stat_user_tables WHERE relname = 'passes'");
    return s.step() && s.getInt(0) != 0;
  };
  auto ingest = [&](int samples) {
    std::vector<json> list;
    for (int i = 0; i < samples; ++i) {
      list.push_back(makeSample(i, 1.0, {makePass("opaque", 0.5, 100, {makeCounter("albedo", "read", 100, 400)})}));
    }
    json result = makeCapture({makeRun("forward", "atrium", 320, 180, std::move(list))});
    json spec = {{"renderers", {"forward"}}};
    auto job = store->jobs().create(spec, std::nullopt, 1);
    ASSERT_TRUE(job) << job.error();
    auto stored = store->runs().ingestCapture(job->job.id, result, {});
    ASSERT_TRUE(stored) << stored.error();
  };
  ingest(10);
  store->runs().waitForStatistics();
  EXPECT_FALSE(analysed()) << "10 samples are below the first analyse";
  ingest(5000);
  store->runs().waitForStatistics();
  EXPECT_TRUE(analysed()) << "5,010 samples stored and no analyse";
}

// The keeper on its own: requests made together are served by at least one
// ANALYZE and at most one each; a database it cannot reach is a failure
// counted with its message, and the next request tries again.
TEST(Engines, StatisticsKeeperAnalysesAndCountsFailures) {
  if (!postgresServer()) GTEST_SKIP() << "runs in store.postgresql (TALLY_TEST_STORE=postgres)";
  TempDb db;
  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  {
    StatisticsKeeper keeper(db.path());
    for (int i = 0; i < 3; ++i) keeper.request();
    keeper.waitIdle();
    auto state = keeper.state();
    EXPECT_GE(state.analyses, 1);
    EXPECT_LE(state.analyses, 3);
    EXPECT_EQ(state.failures, 0) << state.lastFailure;
    EXPECT_EQ(scalar(*store, "SELECT COUNT(*) FROM pg_stat_user_tables WHERE relname = 'passes' AND "
                             "last_analyze IS NOT NULL"),
              1);
  }
  std::string missing = db.path();
  missing = missing.substr(0, missing.rfind('/') + 1) + "tally_no_such_database";
  StatisticsKeeper keeper(missing);
  keeper.request();
  keeper.waitIdle();
  EXPECT_EQ(keeper.state().failures, 1);
  EXPECT_NE(keeper.state().lastFailure.find("tally_no_such_database"), std::string::npos) << keeper.state().lastFailure;
  keeper.request();
  keeper.waitIdle();
  EXPECT_EQ(keeper.state().failures, 2);
  EXPECT_EQ(keeper.state().analyses, 0);
}

TEST(Engines, PostgresStatementsBindAndReadEveryType) {
  if (!postgresServer()) GTEST_SKIP() << "runs in store.postgresql (TALLY_TEST_STORE=postgres)";
  TempDb db;
  auto owner = openPostgres(db.path());
  Connection& c = *owner;
  c.exec("CREATE TABLE t (i BIGINT, r DOUBLE PRECISION, s TEXT, b BYTEA, j TEXT, n TEXT)");
  Statement insert(c, "INSERT INTO t VALUES (:i, :r, :s, :b, :j, :n)");
  const std::vector<uint8_t> blob = {0, 1, 2, 255, '\\', '\''};
  insert.bind(":i", int64_t{1} << 40)
      .bind(":r", 0.1)
      .bind(":s", std::string("it's \"quoted\"; DROP TABLE t; -- ?1 :x $1"))
      .bind(":b", std::span<const uint8_t>(blob))
      .bind(":j", nlohmann::json{{"a", {1, 2}}})
      .bind(":n", std::optional<std::string>());
  insert.run();
  EXPECT_EQ(c.changes(), 1);
  Statement select(c, "SELECT i, r, s, b, j, n, i > 0, 'a literal with ?2 and :name' FROM t WHERE s LIKE ?1");
  select.bind(1, "it's%");
  ASSERT_TRUE(select.step());
  EXPECT_EQ(select.getInt(0), int64_t{1} << 40);
  EXPECT_EQ(select.getDouble(1), 0.1);
  EXPECT_EQ(select.getText(2), "it's \"quoted\"; DROP TABLE t; -- ?1 :x $1");
  EXPECT_EQ(select.getBlob(3), blob);
  EXPECT_EQ(select.getJson(4), (nlohmann::json{{"a", {1, 2}}}));
  EXPECT_TRUE(select.isNull(5));
  EXPECT_EQ(select.getInt(6), 1);  // booleans read as 1 and 0
  EXPECT_EQ(select.getText(7), "a literal with ?2 and :name");
  EXPECT_FALSE(select.step());
  select.reset();
  select.bind(1, "nothing%");
  EXPECT_FALSE(select.step());
  EXPECT_THROW(Statement(c, "SELEKT 1"), DbError);
  c.exec("CREATE TABLE u (x BIGINT NOT NULL)");
  Statement bad(c, "INSERT INTO u VALUES (?1)");
  bad.bind(1, nullptr);
  try {
    bad.run();
    FAIL() << "NOT NULL not enforced";
  } catch (const DbError& e) {
    EXPECT_TRUE(e.isConstraint()) << e.sqlState();
    EXPECT_EQ(e.sqlState(), "23502");
  }
  {
    Transaction tx(c, Transaction::Kind::Write);
    c.exec("INSERT INTO u VALUES (1)");
  }
  {
    Transaction tx(c, Transaction::Kind::Write);
    c.exec("INSERT INTO u VALUES (2)");
    tx.commit();
  }
  Statement all(c, "SELECT string_agg(x::text, ',') FROM u");
  ASSERT_TRUE(all.step());
  EXPECT_EQ(all.getText(0), "2");
}

// Migration 0012 on PostgreSQL: a database of schema 11 with counter rows
// (out of order, with NULLs, quotes and a pass without counters) upgrades to
// arrays on the passes; the view returns every row as it was, in position
// order, and the arrays' check refuses a pass whose arrays disagree.
TEST(Engines, CounterRowsBecomeArraysOnTheirPassKeepingEveryValue) {
  if (!postgresServer()) GTEST_SKIP() << "runs in store.postgresql (TALLY_TEST_STORE=postgres)";
  TempDb db;
  {
    auto c = openPostgres(db.path());
    auto eleven = migrate(*c, embeddedMigrations(Engine::Postgres).first(11));
    ASSERT_TRUE(eleven) << eleven.error();
    ASSERT_EQ(*eleven, 11);
    c->exec(
        "INSERT INTO devices (id, fingerprint, name, vendor, driver, api_version) "
        "VALUES (1, 'llvmpipe', 'llvmpipe', '0x10005', 'Mesa', '1.3');"
        "INSERT INTO scenes (id, name, params) VALUES (1, 'atrium', '{}');"
        "INSERT INTO jobs (id, status, spec, idempotency_key) VALUES (1, 'done', '{}', 'k');"
        "INSERT INTO runs (id, job_id, device_id, renderer, scene_id, width, height, counting, lights) "
        "VALUES (1, 1, 1, 'forward', 1, 64, 36, 'exact', 4);"
        "INSERT INTO samples (id, run_id, camera_index, camera, frame_ms, bytes) VALUES (1, 1, 0, '{}', 1.5, 96);"
        "INSERT INTO passes (id, sample_id, position, name, gpu_ms) VALUES (1, 1, 0, 'opaque', 1.25), "
        "(2, 1, 1, 'none', 0.5), (3, 1, 2, 'tonemap', 0.25);"
        "INSERT INTO counters (pass_id, position, resource, kind, format, access, count, bytes, count_spread, "
        "source, footprint_bytes) VALUES "
        "(1, 2, 'b\"ack\\{x,y}', NULL, 'D32', 'read', 3, 12, NULL, 'derived', 0), "
        "(1, 0, 'depth', 'depth', NULL, 'write', 24, 96, '{\"n\": 20}', 'counter', NULL), "
        "(1, 1, 'NULL', 'texture', 'R8', 'read', 0.1, 0.4, '[1, \"{}\"]', 'counter', 7.5), "
        "(3, 0, 'hdr', 'attachment', 'R16G16B16A16_SFLOAT', 'read', 1e-300, 1.7976931348623157e308, NULL, "
        "'counter', NULL)");
  }
  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  EXPECT_GE(store->schemaVersion(), 12);  // and later ones
  auto& c = store->connection();
  Statement rows(c,
                 "SELECT pass_id, position, resource, COALESCE(kind, '-'), COALESCE(format, '-'), access, count, "
                 "bytes, COALESCE(count_spread, '-'), source, COALESCE(footprint_bytes, -1) FROM counters "
                 "ORDER BY pass_id, position");
  std::vector<std::string> got;
  while (rows.step()) {
    std::string row;
    for (int k = 0; k < 11; ++k) {
      row += (k ? "|" : "") + (k == 6 || k == 7 || k == 10 ? postgresDoubleText(rows.getDouble(k)) : rows.getText(k));
    }
    got.push_back(row);
  }
  EXPECT_EQ(got, (std::vector<std::string>{
                     "1|0|depth|depth|-|write|24|96|{\"n\": 20}|counter|-1",
                     "1|1|NULL|texture|R8|read|0.1|0.4|[1, \"{}\"]|counter|7.5",
                     "1|2|b\"ack\\{x,y}|-|D32|read|3|12|-|derived|0",
                     "3|0|hdr|attachment|R16G16B16A16_SFLOAT|read|1e-300|1.7976931348623157e+308|-|counter|-1"}));
  auto passes = store->runs().passes(1);
  ASSERT_TRUE(passes) << passes.error();
  ASSERT_EQ(passes->size(), 3u);
  EXPECT_EQ((*passes)[0].counters.size(), 3u);
  EXPECT_TRUE((*passes)[1].counters.empty());
  EXPECT_EQ((*passes)[2].counters.size(), 1u);
  // The check: arrays of different lengths or dimensions, a NULL resource,
  // count or source, an unknown access and a negative footprint are refused.
  for (const char* set : {"counter_kinds = '{}'", "counter_bytes = '{1, 2}'", "counter_formats = '{{a}}'",
                          "counter_resources[1] = NULL", "counter_counts[1] = NULL", "counter_sources[1] = NULL",
                          "counter_accesses[1] = 'both'", "counter_footprints[1] = -1"}) {
    SCOPED_TRACE(set);
    try {
      c.exec(std::string("UPDATE passes SET ") + set + " WHERE id = 3");
      ADD_FAILURE() << "accepted";
    } catch (const DbError& e) {
      EXPECT_EQ(e.sqlState(), "23514") << e.what();
    }
  }
  c.exec("UPDATE passes SET counter_footprints[1] = 0, counter_kinds[1] = NULL WHERE id = 3");  // still valid
}

// Daemons of a fleet start together: each opens the store and migrates; one
// applies each migration, the others find it applied (the advisory lock).
TEST(Engines, ConcurrentOpensMigrateOnce) {
  TempDb db;  // either engine
  std::vector<std::thread> daemons;
  std::vector<std::string> errors(6);
  for (size_t i = 0; i < errors.size(); ++i) {
    daemons.emplace_back([&, i] {
      auto store = Store::open(db.path());
      if (!store) errors[i] = store.error();
    });
  }
  for (auto& t : daemons) t.join();
  for (const auto& e : errors) EXPECT_EQ(e, "");
  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  EXPECT_EQ(store->schemaVersion(), latestSchemaVersion());
}

// Rows are read in the SELECT's order, and a row with more or fewer columns
// than were read is refused: a column added to a SELECT cannot shift the others.
TEST(Engines, RowReaderTakesColumnsInOrderAndChecksTheirCount) {
  TempDb db;  // either engine
  auto store = openStore(db.path());
  ASSERT_NE(store, nullptr);
  Statement select(store->connection(), "SELECT 7 AS seven, 'text' AS word, NULL AS absent");
  ASSERT_TRUE(select.step());
  RowReader row(select);
  EXPECT_EQ(row.getInt(), 7);
  EXPECT_EQ(row.getText(), "text");
  EXPECT_TRUE(row.isNull());
  EXPECT_THROW(row.end(), DbError);  // one column left unread
  EXPECT_FALSE(row.getOptText());
  EXPECT_NO_THROW(row.end());
  EXPECT_THROW(row.getInt(), DbError);  // past the last column
  EXPECT_EQ(select.column("word"), 1);
  EXPECT_THROW(select.column("missing"), DbError);
}

TEST(Engines, ParametersAreRewrittenOutsideLiterals) {
  std::vector<std::string> names;
  EXPECT_EQ(toPostgresParameters("SELECT ?2, ?, :a, ':b', \"?\", :a, x::jsonb -- ?9\n, ?", &names),
            "SELECT $2, $3, $4, ':b', \"?\", $4, x::jsonb -- ?9\n, $5");
  ASSERT_EQ(names.size(), 5u);
  EXPECT_EQ(names[3], ":a");
  EXPECT_EQ(redactUrl("postgresql://tally:secret@db.example:5432/tally"), "postgresql://tally:***@db.example:5432/tally");
  EXPECT_EQ(redactUrl("postgresql://db/tally?password=secret&sslmode=require"),
            "postgresql://db/tally?password=***&sslmode=require");
  EXPECT_TRUE(isPostgresUrl("postgres://x"));
  EXPECT_FALSE(isPostgresUrl("/var/lib/tally/tally.db"));
}

}  // namespace
}  // namespace tally::store::testing

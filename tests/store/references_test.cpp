// The references between runs, samples, passes, resources and screenshots
// hold on both engines: SQLite's foreign keys, and on PostgreSQL the
// statement-level checks and cascades of migration 0015, which replaced
// four foreign keys there. Each case is a row a foreign key would refuse, or
// a delete it would follow, checked against the rows counted before and after.
#include <thread>

#include "store/batch_insert.hpp"
#include "store_fixture.hpp"

namespace tally::store::testing {
namespace {

class References : public StoreTest {
 protected:
  // One capture (2 runs x 2 samples x 4 passes, 2 screenshots per run), its job.
  int64_t stored() {
    int64_t job = newJob();
    EXPECT_EQ(ingest(job, realisticCapture(1)), 2);
    return job;
  }
  int64_t count(const std::string& sql) { return scalar(*store_, sql); }
  // The statement is refused as a foreign key refuses it, and changes nothing.
  void expectRefused(const std::string& sql) {
    SCOPED_TRACE(sql);
    auto before = counts();
    try {
      Transaction tx(&store_->connection(), Transaction::Kind::Write);
      store_->connection().exec(sql);
      tx.commit();
      ADD_FAILURE() << "not refused";
    } catch (const DbError& e) {
      EXPECT_TRUE(e.isConstraint()) << e.what();
      if (store_->engine() == Engine::Postgres) {
        EXPECT_EQ(e.sqlState(), "23503") << e.what();
      }
    }
    EXPECT_EQ(counts(), before);
  }
  std::vector<int64_t> counts() {
    std::vector<int64_t> out;
    for (const char* table : {"runs", "samples", "passes", "run_resources", "screenshots"})
      out.push_back(count(std::string("SELECT COUNT(*) FROM ") + table));
    out.push_back(count("SELECT COUNT(*) FROM samples WHERE screenshot_id IS NULL"));
    return out;
  }
};

TEST_F(References, ChildRowNamingAMissingParentIsRefused) {
  stored();
  int64_t sample = count("SELECT MIN(id) FROM samples"), run = count("SELECT MIN(id) FROM runs");
  int64_t missing = 1 << 30;
  expectRefused("INSERT INTO passes (sample_id, position, name, gpu_ms) VALUES (" + std::to_string(missing) +
                ", 99, 'p', 1)");
  expectRefused("INSERT INTO samples (run_id, camera_index, camera, frame_ms) VALUES (" + std::to_string(missing) +
                ", 99, '{}', 1)");
  expectRefused("INSERT INTO samples (run_id, camera_index, camera, frame_ms, screenshot_id) VALUES (" +
                std::to_string(run) + ", 99, '{}', 1, " + std::to_string(missing) + ")");
  expectRefused("INSERT INTO run_resources (run_id, position, name, kind) VALUES (" + std::to_string(missing) +
                ", 99, 'r', 'buffer')");
  // One bad row among good ones refuses the whole statement.
  expectRefused("INSERT INTO passes (sample_id, position, name, gpu_ms) VALUES (" + std::to_string(sample) +
                ", 98, 'p', 1), (" + std::to_string(missing) + ", 99, 'p', 1)");
  // Changing a child's parent to one that does not exist.
  expectRefused("UPDATE passes SET sample_id = " + std::to_string(missing) + " WHERE id = (SELECT MIN(id) FROM passes)");
  expectRefused("UPDATE samples SET run_id = " + std::to_string(missing) + " WHERE id = " + std::to_string(sample));
  expectRefused("UPDATE samples SET screenshot_id = " + std::to_string(missing) + " WHERE id = " +
                std::to_string(sample));
  expectRefused("UPDATE run_resources SET run_id = " + std::to_string(missing) +
                " WHERE id = (SELECT MIN(id) FROM run_resources)");
  // Changing a parent's id under its children.
  expectRefused("UPDATE runs SET id = " + std::to_string(missing) + " WHERE id = " + std::to_string(run));
  expectRefused("UPDATE samples SET id = " + std::to_string(missing) + " WHERE id = " + std::to_string(sample));
  expectRefused("UPDATE screenshots SET id = " + std::to_string(missing) +
                " WHERE id = (SELECT MIN(screenshot_id) FROM samples)");
  // Rows naming parents that exist go in, and may move to another that exists.
  store_->connection().exec("INSERT INTO passes (sample_id, position, name, gpu_ms) VALUES (" +
                            std::to_string(sample) + ", 99, 'p', 1)");
  int64_t other = count("SELECT MAX(id) FROM samples");
  store_->connection().exec("UPDATE passes SET sample_id = " + std::to_string(other) +
                            " WHERE sample_id = " + std::to_string(sample) + " AND position = 99");
  EXPECT_EQ(count("SELECT COUNT(*) FROM passes WHERE position = 99 AND sample_id = " + std::to_string(other)), 1);
}

// The ingest's own path: rows sent through COPY (PostgreSQL) or batched
// INSERTs (SQLite) naming a missing parent are refused when the batch ends.
TEST_F(References, BatchNamingAMissingParentIsRefused) {
  stored();
  int64_t sample = count("SELECT MIN(id) FROM samples");
  auto before = counts();
  Connection& db = store_->connection();
  try {
    Transaction tx(&db, Transaction::Kind::Write);
    detail::BatchInsert passes(&db, "passes", {"sample_id", "position", "name", "gpu_ms"});
    for (int p = 0; p < 300; ++p) passes.row().add(sample).add(int64_t{100 + p}).add("p").add(1.0);
    passes.row().add(int64_t{1} << 30).add(int64_t{99}).add("p").add(1.0);
    passes.flush();
    tx.commit();
    ADD_FAILURE() << "not refused";
  } catch (const DbError& e) {
    EXPECT_TRUE(e.isConstraint()) << e.what();
    if (store_->engine() == Engine::Postgres) {
      EXPECT_NE(std::string(e.what()).find("Key (sample_id)=(1073741824) is not present in table \"samples\""),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(counts(), before);
}

// Deletes follow as the foreign keys' ON DELETE actions did: a run takes its
// samples, their passes and its resources; a sample its passes; a screenshot
// leaves its sample without one; a job (a foreign key of its own) takes its
// runs and everything below them.
TEST_F(References, DeletesFollowToTheChildren) {
  int64_t kept = stored(), job = stored();
  auto keptCounts = counts();
  Connection& db = store_->connection();
  int64_t run = count("SELECT MIN(id) FROM runs WHERE job_id = " + std::to_string(job));
  auto ofRun = [&](const std::string& table) {
    return count("SELECT COUNT(*) FROM " + table + " WHERE run_id = " + std::to_string(run));
  };
  auto passesOfRun = [&] {
    return count("SELECT COUNT(*) FROM passes p JOIN samples s ON s.id = p.sample_id WHERE s.run_id = " +
                 std::to_string(run));
  };
  ASSERT_EQ(ofRun("samples"), 2);
  ASSERT_EQ(passesOfRun(), 8);
  ASSERT_GT(ofRun("run_resources"), 0);
  int64_t sample = count("SELECT MIN(id) FROM samples WHERE run_id = " + std::to_string(run));
  int64_t shot = count("SELECT screenshot_id FROM samples WHERE id = " + std::to_string(sample));
  int64_t passesBefore = count("SELECT COUNT(*) FROM passes");
  db.exec("DELETE FROM screenshots WHERE id = " + std::to_string(shot));
  EXPECT_EQ(count("SELECT COUNT(*) FROM samples WHERE screenshot_id IS NULL AND id = " + std::to_string(sample)), 1);
  EXPECT_EQ(count("SELECT COUNT(*) FROM samples"), keptCounts[1]);
  db.exec("DELETE FROM samples WHERE id = " + std::to_string(sample));
  EXPECT_EQ(count("SELECT COUNT(*) FROM passes"), passesBefore - 4);
  EXPECT_EQ(count("SELECT COUNT(*) FROM passes WHERE sample_id = " + std::to_string(sample)), 0);
  db.exec("DELETE FROM runs WHERE id = " + std::to_string(run));
  EXPECT_EQ(ofRun("samples"), 0);
  EXPECT_EQ(ofRun("run_resources"), 0);
  EXPECT_EQ(count("SELECT COUNT(*) FROM passes WHERE sample_id NOT IN (SELECT id FROM samples)"), 0);
  db.exec("DELETE FROM jobs WHERE id = " + std::to_string(job));
  EXPECT_EQ(count("SELECT COUNT(*) FROM runs WHERE job_id = " + std::to_string(job)), 0);
  // What is left is the other job's, whole: its rows and screenshots, less
  // the deleted job's screenshots, which no foreign key removes.
  auto left = counts();
  EXPECT_EQ(left[0], keptCounts[0] / 2);
  EXPECT_EQ(left[1], keptCounts[1] / 2);
  EXPECT_EQ(left[2], keptCounts[2] / 2);
  EXPECT_EQ(left[3], keptCounts[3] / 2);
  EXPECT_EQ(left[5], 0);
  EXPECT_EQ(count("SELECT COUNT(*) FROM samples s JOIN runs r ON r.id = s.run_id WHERE r.job_id = " +
                  std::to_string(kept)),
            keptCounts[1] / 2);
}

// A parent named by an uncommitted child is locked as a foreign key's check
// locks it: another connection's delete waits for it (and here gives up at
// its lock timeout) instead of leaving the child without its parent.
TEST_F(References, ParentOfAnUncommittedChildCannotBeDeletedMeanwhile) {
  if (store_->engine() != Engine::Postgres) GTEST_SKIP() << "SQLite has one writer at a time";
  stored();
  int64_t run = count("SELECT MIN(id) FROM runs");
  Connection& db = store_->connection();
  Transaction tx(&db, Transaction::Kind::Write);
  db.exec("INSERT INTO run_resources (run_id, position, name, kind) VALUES (" + std::to_string(run) +
          ", 99, 'r', 'buffer')");
  auto other = openPostgres(db_.path());
  other->exec("SET lock_timeout = '200ms'");
  try {
    other->exec("DELETE FROM runs WHERE id = " + std::to_string(run));
    ADD_FAILURE() << "the parent was deleted under an uncommitted child";
  } catch (const DbError& e) {
    EXPECT_EQ(e.sqlState(), "55P03") << e.what();  // lock_not_available
  }
  tx.commit();
  EXPECT_EQ(count("SELECT COUNT(*) FROM run_resources WHERE position = 99 AND run_id = " + std::to_string(run)), 1);
}

}  // namespace
}  // namespace tally::store::testing

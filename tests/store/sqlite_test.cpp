// The Statement/Transaction wrapper: binding by index and name, getters,
// errors, rollback by default.
#include "store/sqlite.hpp"

#include "store/fault.hpp"

#include <gtest/gtest.h>

namespace tally::store {
namespace {

struct Db {
  std::unique_ptr<Connection> owner = openSqlite(":memory:", true, 5000);
  Connection& db = *owner;
};

TEST(Statement, BindsAndReadsEveryType) {
  Db d;
  d.db.exec("CREATE TABLE t (i INTEGER, r REAL, s TEXT, b BLOB, j TEXT, n TEXT)");
  Statement insert(d.db, "INSERT INTO t VALUES (:i, :r, :s, :b, :j, :n)");
  const std::vector<uint8_t> blob = {0, 1, 2, 255};
  insert.bind(":i", int64_t{1} << 40)
      .bind(":r", 0.1)
      .bind(":s", std::string("it's \"quoted\"; DROP TABLE t; --"))
      .bind(":b", std::span<const uint8_t>(blob))
      .bind(":j", nlohmann::json{{"a", {1, 2}}})
      .bind(":n", std::optional<std::string>());
  insert.run();
  Statement select(d.db, "SELECT i, r, s, b, j, n FROM t WHERE s LIKE ?1");
  select.bind(1, "it's%");
  ASSERT_TRUE(select.step());
  EXPECT_EQ(select.getInt(0), int64_t{1} << 40);
  EXPECT_EQ(select.getDouble(1), 0.1);
  EXPECT_EQ(select.getText(2), "it's \"quoted\"; DROP TABLE t; --");
  EXPECT_EQ(select.getBlob(3), blob);
  EXPECT_EQ(select.getJson(4), (nlohmann::json{{"a", {1, 2}}}));
  EXPECT_TRUE(select.isNull(5));
  EXPECT_FALSE(select.getOptText(5));
  EXPECT_EQ(select.getOptInt(0), int64_t{1} << 40);
  EXPECT_TRUE(select.getJson(5).is_null());
  EXPECT_FALSE(select.step());
  // Reset and run again with other values.
  select.reset();
  select.bind(1, "nothing%");
  EXPECT_FALSE(select.step());
}

TEST(Statement, ErrorsThrowWithTheReason) {
  Db d;
  EXPECT_THROW(Statement(d.db, "SELEKT 1"), DbError);
  d.db.exec("CREATE TABLE t (x INTEGER NOT NULL)");
  Statement insert(d.db, "INSERT INTO t VALUES (?1)");
  EXPECT_THROW(insert.bind(":missing", 1), DbError);
  insert.bind(1, nullptr);
  try {
    insert.run();
    FAIL() << "NOT NULL not enforced";
  } catch (const DbError& e) {
    EXPECT_EQ(e.code() & 0xff, SQLITE_CONSTRAINT);
    EXPECT_NE(std::string(e.what()).find("NOT NULL"), std::string::npos) << e.what();
  }
}

TEST(Transaction, RollsBackUnlessCommitted) {
  Db d;
  d.db.exec("CREATE TABLE t (x)");
  {
    Transaction tx(d.db, Transaction::Kind::Write);
    d.db.exec("INSERT INTO t VALUES (1)");
  }
  {
    Transaction tx(d.db, Transaction::Kind::Write);
    d.db.exec("INSERT INTO t VALUES (2)");
    tx.commit();
  }
  Statement count(d.db, "SELECT group_concat(x) FROM t");
  ASSERT_TRUE(count.step());
  EXPECT_EQ(count.getText(0), "2");
}

// Store faults are named from the engine's code, not its message.
TEST(Faults, NamedFromTheEngineCodes) {
  struct Case {
    DbError error;
    Fault fault;
  };
  const Case cases[] = {
      {DbError(SQLITE_FULL, "", "x"), Fault::kFull},
      {DbError(SQLITE_IOERR_WRITE, "", "x"), Fault::kIoError},
      {DbError(SQLITE_IOERR_FSYNC, "", "x"), Fault::kIoError},
      {DbError(SQLITE_CORRUPT, "", "x"), Fault::kDamaged},
      {DbError(SQLITE_NOTADB, "", "x"), Fault::kDamaged},
      {DbError(SQLITE_BUSY, "", "x"), Fault::kBusy},
      {DbError(SQLITE_BUSY_SNAPSHOT, "", "x"), Fault::kBusy},
      {DbError(SQLITE_READONLY, "", "x"), Fault::kReadOnly},
      {DbError(SQLITE_CONSTRAINT_UNIQUE, "", "x"), Fault::kNone},
      {DbError(SQLITE_ERROR, "", "x"), Fault::kNone},
      {DbError(0, "08006", "x"), Fault::kUnreachable},
      {DbError(0, "57P01", "x"), Fault::kUnreachable},
      {DbError(0, "53100", "x"), Fault::kFull},
      {DbError(0, "55P03", "x"), Fault::kBusy},
      {DbError(0, "XX001", "x"), Fault::kDamaged},
      {DbError(0, "23505", "x"), Fault::kNone},
      {DbError(0, "42601", "x"), Fault::kNone},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(faultOf(c.error), c.fault) << c.error.code() << " " << c.error.sqlState();
    EXPECT_EQ(faultOf(static_cast<const std::exception&>(c.error)), c.fault);
  }
  EXPECT_EQ(faultOf(std::runtime_error("not the store's")), Fault::kNone);
  EXPECT_TRUE(isWriteFault(Fault::kFull));
  EXPECT_FALSE(isWriteFault(Fault::kDamaged));
  EXPECT_STREQ(toString(Fault::kIoError), "io_error");
  EXPECT_NE(describe(Fault::kFull).find("full"), std::string::npos);
}

}  // namespace
}  // namespace tally::store

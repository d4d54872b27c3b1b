// The throwaway PostgreSQL server of tests/support/postgres_server.hpp: its
// databases are separate, and stop() leaves no server behind.
#include "postgres_server.hpp"

#include <libpq-fe.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <memory>
#include <string>

#include "proc_file.hpp"
#include "read_file.hpp"

namespace tally::testing {
namespace {

using Connection = std::unique_ptr<PGconn, decltype(&PQfinish)>;

Connection connect(const std::string& url) { return {PQconnectdb(url.c_str()), &PQfinish}; }

// Runs sql; the first column of each row, one per line ("" for a command).
std::string query(PGconn* conn, const std::string& sql) {
  PGresult* result = PQexec(conn, sql.c_str());
  std::string text;
  ExecStatusType status = PQresultStatus(result);
  if (status == PGRES_TUPLES_OK) {
    for (int row = 0; row < PQntuples(result); ++row) text += std::string(PQgetvalue(result, row, 0)) + "\n";
  } else if (status != PGRES_COMMAND_OK) {
    ADD_FAILURE() << sql << ": " << PQresultErrorMessage(result);
  }
  PQclear(result);
  return text;
}

// Alive and not a zombie (the postmaster's adopter may never reap it).
bool processAlive(pid_t pid) {
  std::string stat = tally::test::readProcFile("/proc/" + std::to_string(pid) + "/stat");
  size_t paren = stat.rfind(')');
  return paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] != 'Z';
}

TEST(PostgresServer, DatabasesAreSeparate) {
  PostgresServer* pg = requirePostgres();
  if (pg == nullptr) return;
  EXPECT_EQ(pg->url(), "postgresql://tally@127.0.0.1:" + std::to_string(pg->port()) + "/tally");

  std::string urlA = pg->createDatabase("separate_a");
  std::string urlB = pg->createDatabase();
  EXPECT_EQ(urlA, pg->url("separate_a"));
  EXPECT_NE(urlA, urlB);

  Connection a = connect(urlA), b = connect(urlB);
  ASSERT_EQ(PQstatus(a.get()), CONNECTION_OK) << PQerrorMessage(a.get());
  ASSERT_EQ(PQstatus(b.get()), CONNECTION_OK) << PQerrorMessage(b.get());
  query(a.get(), "CREATE TABLE only_in_a (id integer)");
  query(b.get(), "CREATE TABLE only_in_b (id integer)");
  const std::string tables = "SELECT table_name FROM information_schema.tables WHERE table_schema = 'public'";
  EXPECT_EQ(query(a.get(), tables), "only_in_a\n");
  EXPECT_EQ(query(b.get(), tables), "only_in_b\n");

  // A taken name is the server's refusal, as an exception.
  EXPECT_THROW(pg->createDatabase("separate_a"), std::runtime_error);
  // The shared server is the same one each time.
  EXPECT_EQ(requirePostgres(), pg);
}

TEST(PostgresServer, StopEndsTheServer) {
  PostgresServer pg;
  if (!requireStarted(pg)) return;
  ASSERT_TRUE(pg.running());
  EXPECT_FALSE(tally::test::readFile(pg.logPath()).empty());
  const std::filesystem::path dataDir = pg.dataDir();
  const pid_t pid = std::atoi(tally::test::readFile(dataDir / "postmaster.pid").c_str());
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(processAlive(pid));
  {
    Connection conn = connect(pg.url());
    EXPECT_EQ(PQstatus(conn.get()), CONNECTION_OK) << PQerrorMessage(conn.get());
  }

  pg.stop();
  EXPECT_FALSE(pg.running());
  EXPECT_FALSE(processAlive(pid)) << "postmaster " << pid << " of " << dataDir << " still runs";
  EXPECT_FALSE(std::filesystem::exists(dataDir));
  pg.stop();  // a second stop does nothing
}

TEST(PostgresServer, MissingBinariesAreReported) {
  PostgresServer pg("/nonexistent/postgresql/bin");
  std::optional<std::string> error = pg.start();
  ASSERT_TRUE(error.has_value());
  EXPECT_NE(error->find("PostgreSQL is not installed"), std::string::npos) << *error;
  EXPECT_FALSE(pg.running());
}

}  // namespace
}  // namespace tally::testing

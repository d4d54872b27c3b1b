// A private, throwaway PostgreSQL server for tests: its own cluster in a
// temporary folder (initdb), listening on a free port of 127.0.0.1 only,
// superuser "tally" with trust authentication, fsync off. Gone, folder and
// all, when stop() runs or the object is destroyed.
//
// The binaries are the installed server's (pg_config --bindir, else the
// highest /usr/lib/postgresql/*/bin, else PATH). initdb and postgres refuse
// to run as root, so under euid 0 they run as the "postgres" system user
// (Debian's postgresql-common creates it) through setpriv, in a folder owned
// by that user. A watchdog (a detached shell) stops the server and removes
// the folder should the test process die without stop(): killed, crashed,
// timed out by ctest.
//
// Most tests want the process's one shared server (starting one takes about
// a second) and a database of their own on it:
//
//   TEST(Fleet, Something) {
//     auto* pg = tally::testing::requirePostgres();
//     if (pg == nullptr) return;  // skipped, or failed where tests are strict (strict.hpp)
//     std::string url = pg->createDatabase();  // postgresql://tally@127.0.0.1:PORT/test_1
//     ...
//   }
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

typedef struct pg_conn PGconn;  // <libpq-fe.h>, kept out of the tests that include this

namespace tally::testing {

class PostgresServer {
 public:
  // binDir: where initdb, pg_ctl and postgres are; empty finds them (above).
  explicit PostgresServer(std::filesystem::path binDir = {});
  ~PostgresServer();  // stop()
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // Creates the cluster, starts the server and creates the database "tally".
  // nullopt once running; otherwise why not (no PostgreSQL installed, no
  // "postgres" user under root, initdb or pg_ctl failing: their output and
  // the server log's end), with nothing left behind.
  std::optional<std::string> start();
  // pg_ctl stop -m fast, then waits until the postmaster has exited and
  // removes the folder (log included). Does nothing when not running, and
  // in a forked child of the process that started the server.
  void stop();
  bool running() const { return port_ != 0; }

  // postgresql://tally@127.0.0.1:PORT/DATABASE (the name percent-encoded).
  std::string url(std::string_view database = "tally") const;
  // CREATE DATABASE through a connection to the maintenance database
  // "postgres" (tens of milliseconds); returns its url(). An empty name
  // makes a new one (test_1, test_2, ...). Throws std::runtime_error when
  // the server refuses (the name taken, longer than 63 bytes, ...). Safe
  // from several threads; start() and stop() are not.
  std::string createDatabase(std::string_view name = {});

  int port() const { return port_; }
  // The server's log (pg_ctl -l), there while it runs.
  const std::filesystem::path& logPath() const { return log_; }
  // The cluster: postmaster.pid in it names the postmaster while it runs.
  const std::filesystem::path& dataDir() const { return data_; }

 private:
  std::optional<std::string> tryStart();
  void cleanUp();

  std::filesystem::path binDir_;
  std::filesystem::path root_, data_, socketDir_, log_;  // root_: the temporary folder
  int port_ = 0;
  pid_t owner_ = 0;      // the process that started the server
  int watchdogFd_ = -1;  // the watchdog's pipe: closing it (exit, crash) sets it off
  std::mutex mutex_;     // admin_ and counter_
  PGconn* admin_ = nullptr;
  int counter_ = 0;
};

// The process's shared server, started on first use and stopped at exit.
// nullptr when it cannot start: the current test is then marked skipped, or
// failed (a fatal failure) where tests are strict (strict.hpp: CI=true, or scripts/test.sh), where
// PostgreSQL must be installed. Either way the test body should return; a
// fixture's SetUp() may call it too (gtest then runs no body).
PostgresServer* requirePostgres();
// The same for a server of the test's own (one it stops, say): starts it,
// and false, the test skipped or failed as above, when it cannot start.
bool requireStarted(PostgresServer& server);

}  // namespace tally::testing

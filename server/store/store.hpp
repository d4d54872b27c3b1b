// Tally's store: capture jobs (a persistent queue), ingested capture
// results, and the queries the service layer turns into JSON. One interface
// over two engines (db.hpp): a SQLite file, the default for one host, or a
// PostgreSQL database that a fleet of daemons shares (docs/fleet.md).
//
// Facets. A Store's calls are grouped by what they handle: jobs() the job
// queue, hosts() the fleet's hosts, runs() stored results and their queries,
// alerts() baselines, alerts and the webhook's outbox. Each facet is a view
// of the Store's one connection (facet.hpp) and lives as long as the Store.
//
// Connections and threads. A Store is one connection; its calls, whichever
// facet makes them, are serialised by one mutex, so sharing a Store between
// threads is safe but slow.
// The daemon opens:
//   - one writer:  Store::open(path)            migrates, then takes writes;
//   - one reader per thread (HTTP workers):  Store::open(path, {.readOnly = true})
//     after the writer has migrated. Readers never block the writer (WAL) and
//     read a consistent snapshot per call; busy_timeout covers the moments
//     (WAL recovery, checkpoints) when SQLite briefly makes them wait.
// All write transactions in the process are additionally serialised by one
// process-wide mutex (one writer), and use BEGIN IMMEDIATE, so two processes
// on one file wait on busy_timeout instead of failing. On PostgreSQL the same
// shape holds (a writer that migrates, readers per thread) without the
// process-wide mutex: the server orders concurrent writers.
//
// Errors come back as tally::Result with a one-line reason; "not found" is an
// empty optional, not an error.
#pragma once

#include <memory>
#include <string>

#include "common/result.hpp"
#include "store/alerts.hpp"
#include "store/db.hpp"
#include "store/facet.hpp"
#include "store/fault.hpp"
#include "store/hosts.hpp"
#include "store/jobs.hpp"
#include "store/runs.hpp"

namespace tally::store {

class Store {
 public:
  struct Options {
    bool readOnly = false;     // a reader: no migrations, no writes (PRAGMA query_only)
    int busyTimeoutMs = 5000;  // how long to wait on another connection's lock
  };

  // Opens (creating when writable) and migrates. location is a SQLite file
  // path or a postgresql:// URL (isPostgresUrl). Refuses a database whose
  // schema is newer than this binary's, naming both versions.
  static Result<std::unique_ptr<Store>> open(const std::string& location, Options options);
  static Result<std::unique_ptr<Store>> open(const std::string& location) { return open(location, Options{}); }
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  int schemaVersion() const { return schemaVersion_; }

  JobQueue& jobs() { return jobs_; }
  Hosts& hosts() { return hosts_; }
  Runs& runs() { return runs_; }
  Alerts& alerts() { return alerts_; }

  // SQLite: PRAGMA integrity_check's first line ("ok" when healthy) and no
  // foreign key violations. PostgreSQL enforces both as it writes: "ok" when
  // the server answers.
  Result<std::string> integrityCheck();
  // The store's health check, cheap enough to run on a schedule: SQLite's
  // PRAGMA quick_check (its first three lines; "ok" when healthy; O(N) in the
  // file's size, without integrity_check's index cross-checks), PostgreSQL's
  // round trip ("ok" when the server answers). Run it on a connection of its
  // own: it holds this one for as long as it reads.
  Result<std::string> quickCheck();
  // Whether the store takes a write again (after a full disk): SQLite
  // rewrites one header field with its own value and commits; PostgreSQL
  // answers a round trip.
  Result<bool> probeWrite();

  // The connection, for tests and tools; not for concurrent use.
  Connection& connection() { return *shared_.db; }
  Engine engine() const { return shared_.db->engine(); }
  // What open() was given: a SQLite path or a postgresql:// URL (JobWaiter::open takes it).
  const std::string& location() const { return shared_.location; }

 private:
  Store(std::unique_ptr<Connection> db, int version, const std::string& location);
  std::unique_ptr<Connection> owner_;
  Shared shared_;
  int schemaVersion_;
  JobQueue jobs_;
  Hosts hosts_;
  Runs runs_;
  Alerts alerts_;
};

}  // namespace tally::store

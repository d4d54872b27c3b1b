// The SQLite engine of db.hpp. The store opens it through openSqlite(); tests
// and tools that need the raw handle (pragmas, plans) cast to SqliteConnection.
#pragma once

#include <sqlite3.h>

#include <string>

#include "store/db.hpp"

namespace tally::store {

class SqliteConnection final : public Connection {
 public:
  // Takes ownership of db (closed in the destructor) unless owns is false.
  SqliteConnection(sqlite3* db, std::string path, bool owns = true)
      : db_(db), path_(std::move(path)), owns_(owns) {}
  ~SqliteConnection() override;
  Engine engine() const override { return Engine::Sqlite; }
  void exec(std::string_view sql) override;
  std::unique_ptr<StatementImpl> prepare(std::string_view sql) override;
  int64_t changes() const override { return sqlite3_changes64(db_); }
  std::string describe() const override { return path_; }
  sqlite3* raw() { return db_; }

 private:
  sqlite3* db_;
  std::string path_;
  bool owns_;
};

// Throws DbError when rc is not SQLITE_OK/ROW/DONE.
void check(sqlite3* db, int rc, std::string_view what);

}  // namespace tally::store

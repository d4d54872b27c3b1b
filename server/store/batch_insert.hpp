// Rows of one table written in batches instead of one statement per row: a
// capture of 200 samples is about 7,000 rows, and on PostgreSQL one
// statement per row was one network round trip per row (424 samples/s).
//
//   BatchInsert counters(db, "counters", {"pass_id", "position", "resource"});
//   counters.row().add(passId).add(int64_t{0}).add(name);
//   counters.flush();   // inside the caller's transaction
//
// PostgreSQL takes the rows through COPY (one command, the rows streamed in
// its text format, or in its binary format where the table asks for it;
// send() hands over the rows read so far and keeps the copy open, so that
// the server stores them while the caller reads the next); SQLite through
// prepared multi-row INSERTs of up to
// kSqliteRowsPerStatement rows. Values are stored exactly as Statement::bind
// stores them (the same text for numbers and JSON), so a batched row reads
// back as a row inserted alone would.
//
// Rows that other rows of the same batch refer to need their ids before they
// are written: reserveIds gives a table's next ids (PostgreSQL: from its
// identity sequence; SQLite: after the largest id, which holds because a
// write transaction excludes every other writer). Write them in the id
// column like any other value.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/db.hpp"

namespace tally::store::detail {

// A PostgreSQL array of text or of double precision in COPY's binary form
// (array_recv's: one dimension, or none when empty; whether an element is
// NULL; the element type; then each element's length and bytes), built
// element by element for an array column of a kBinary BatchInsert. An
// element of the other type is a programming error (std::logic_error).
class BinaryArray {
 public:
  enum class Of { kText, kFloat8 };
  explicit BinaryArray(Of of) : of_(of) {}
  BinaryArray& add(std::string_view text);  // kText: any bytes of valid UTF-8
  BinaryArray& add(const std::string& text) { return add(std::string_view(text)); }
  BinaryArray& add(double value);  // kFloat8
  BinaryArray& add(std::nullptr_t);
  BinaryArray& add(const nlohmann::json& value);  // kText: compact JSON text, as BatchInsert::add
  BinaryArray& add(const nlohmann::json* value) { return value ? add(*value) : add(nullptr); }  // null: NULL
  template <class T>
  BinaryArray& add(const std::optional<T>& value) {
    return value ? add(*value) : add(nullptr);
  }
  // The array's bytes; the array is empty again afterwards.
  std::string take();

 private:
  Of of_;
  std::string elements_;
  int32_t count_ = 0;
  bool nulls_ = false;
};

// One PostgreSQL COPY fed with pieces of rows already formatted
// (BatchInsert::take), which another thread may have formatted: the first
// piece begins the copy (with the binary header where it is binary),
// finish() ends it. Destroyed while open, it aborts the copy, whose
// transaction must then roll back.
class CopyStream {
 public:
  CopyStream(Connection* db, std::string statement, bool binary)
      : db_(db), statement_(std::move(statement)), binary_(binary) {}
  ~CopyStream();
  CopyStream(const CopyStream&) = delete;
  CopyStream& operator=(const CopyStream&) = delete;
  void send(std::string_view piece);
  void finish();

 private:
  Connection* db_;
  std::string statement_;
  bool binary_;
  bool open_ = false;
};

class BatchInsert {
 public:
  // kBinary (PostgreSQL; SQLite ignores it): COPY's binary format, which the
  // server reads without parsing text (arrays and doubles above all: half
  // of the passes' COPY as text). Each value must then be of its column's
  // type exactly: int64_t for BIGINT, double for DOUBLE PRECISION, text for
  // TEXT, bytes for BYTEA, a BinaryArray of the column's element type.
  enum class Format { kText, kBinary };
  BatchInsert(Connection* db, std::string table, std::vector<std::string> columns, Format format = Format::kText);

  // Starts a row; its values follow with add(), one per column in order.
  BatchInsert& row();
  BatchInsert& add(std::nullptr_t) { return put(nullptr); }
  BatchInsert& add(int64_t value) { return put(value); }
  BatchInsert& add(int value) { return put(int64_t{value}); }
  BatchInsert& add(double value) { return put(value); }
  BatchInsert& add(std::string value) { return put(std::move(value)); }
  BatchInsert& add(const char* value) { return put(std::string(value)); }
  BatchInsert& add(std::string_view value) { return put(std::string(value)); }
  // Borrowed: the bytes must outlive flush().
  BatchInsert& add(std::span<const uint8_t> blob) { return put(blob); }
  BatchInsert& add(const nlohmann::json& value);  // compact JSON text, as Statement::bind
  BatchInsert& add(const nlohmann::json* value) { return value ? add(*value) : add(nullptr); }  // null: NULL
  template <class T>
  BatchInsert& add(const std::optional<T>& value) {
    return value ? add(*value) : add(nullptr);
  }
  // An array column (kBinary only); the array is empty again afterwards.
  BatchInsert& add(BinaryArray& array);

  BatchInsert(const BatchInsert&) = delete;
  BatchInsert& operator=(const BatchInsert&) = delete;
  ~BatchInsert();  // a copy left open is aborted: its transaction must roll back

  size_t rows() const { return cells_.size() / columns_.size(); }
  // Writes the rows held and forgets them. Throws DbError (the engine's
  // message) or std::logic_error for a row of the wrong width.
  void flush();
  // The same, but PostgreSQL's COPY stays open for more rows, which the
  // server stores while the caller reads the next; flush() ends it. Nothing
  // else may run on the connection until then.
  void send();

  // PostgreSQL: the rows held, formatted for COPY (without the binary
  // header and trailer: a CopyStream adds them), and forgotten; the
  // connection is not used, so one thread may format while another sends
  // with a CopyStream of copyStatement().
  std::string take();
  std::string copyStatement() const;  // COPY table (columns) FROM STDIN [WITH (FORMAT binary)]
  Format format() const { return format_; }

  // SQLite's limit on parameters per statement is 32,766; 256 rows of the
  // widest table (samples, 27 columns) stay well within it.
  static constexpr size_t kSqliteRowsPerStatement = 256;

 private:
  struct Encoded {  // a value already in COPY's binary form (an array)
    std::string bytes;
  };
  using Cell = std::variant<std::nullptr_t, int64_t, double, std::string, std::span<const uint8_t>, Encoded>;
  BatchInsert& put(Cell cell);
  void write(bool end);
  void flushSqlite();
  void sendPostgres(bool end);
  void appendText(std::string& data) const;
  void appendBinary(std::string& data) const;
  std::string insertSql(size_t rows) const;

  Connection* db_;
  std::string table_;
  std::vector<std::string> columns_;
  std::vector<Cell> cells_;
  std::optional<Statement> full_;  // SQLite: the statement of a full chunk, prepared once
  Format format_;
  CopyStream copy_;  // PostgreSQL: the copy that send() leaves open
};


// For each (table, count): `count` new ids of the table's id column,
// ascending; no other writer gets them. PostgreSQL: one statement for all.
std::vector<std::vector<int64_t>> reserveIds(Connection* db,
                                             std::span<const std::pair<std::string_view, size_t>> tables);

}  // namespace tally::store::detail

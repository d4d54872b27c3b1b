#include "store/batch_insert.hpp"

#include <algorithm>
#include <bit>
#include <stdexcept>
#include <type_traits>

namespace tally::store::detail {

namespace {

// COPY's text format: backslash, and the row and column separators, escaped.
void appendCopyText(std::string& out, std::string_view text) {
  // Runs without a character to escape go in whole. One test per character:
  // find_first_of with a set of four searched the set for every character.
  auto special = [](char c) { return c == '\\' || c == '\n' || c == '\r' || c == '\t'; };
  size_t run = 0;
  for (size_t at = 0; at < text.size(); ++at) {
    char c = text[at];
    if (!special(c)) continue;
    out.append(text, run, at - run);
    out += c == '\\' ? "\\\\" : c == '\n' ? "\\n" : c == '\r' ? "\\r" : "\\t";
    run = at + 1;
  }
  out.append(text, run, text.size() - run);
}

// bytea's hex input form ("\x0a1b..."), its backslash escaped for COPY.
void appendCopyBytea(std::string& out, std::span<const uint8_t> bytes) {
  static const char kHex[] = "0123456789abcdef";
  out += "\\\\x";
  for (uint8_t b : bytes) {
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
}

// COPY's binary format: integers in network byte order.
void appendBig32(std::string& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((v >> shift) & 0xff);
}
void appendBig64(std::string& out, uint64_t v) {
  for (int shift = 56; shift >= 0; shift -= 8) out += static_cast<char>((v >> shift) & 0xff);
}
void appendBig16(std::string& out, uint16_t v) {
  out += static_cast<char>(v >> 8);
  out += static_cast<char>(v & 0xff);
}
// A field: its length, then its bytes.
void appendField(std::string& out, std::string_view bytes) {
  appendBig32(out, static_cast<uint32_t>(bytes.size()));
  out.append(bytes);
}

// The signature, no flags, no header extension (PostgreSQL's COPY, "Binary Format").
constexpr std::string_view kBinaryHeader{"PGCOPY\n\377\r\n\0\0\0\0\0\0\0\0\0", 19};

}  // namespace

CopyStream::~CopyStream() {
  if (open_) db_->copyAbort();
}

void CopyStream::send(std::string_view piece) {
  if (!open_) {
    db_->copyBegin(statement_);
    open_ = true;
    if (binary_) db_->copyData(kBinaryHeader);
  }
  if (!piece.empty()) db_->copyData(piece);
}

void CopyStream::finish() {
  if (!open_) return;
  if (binary_) db_->copyData(std::string_view("\xff\xff", 2));  // the trailer: a row of -1 fields
  open_ = false;
  db_->copyEnd();
}

BatchInsert::BatchInsert(Connection* db, std::string table, std::vector<std::string> columns, Format format)
    : db_(db),
      table_(std::move(table)),
      columns_(std::move(columns)),
      format_(format),
      copy_(db, copyStatement(), format == Format::kBinary) {
  if (columns_.empty()) throw std::logic_error("BatchInsert: no columns for " + table_);
}

BatchInsert& BatchInsert::row() {
  if (cells_.size() % columns_.size() != 0) {
    throw std::logic_error("BatchInsert: a row of " + table_ + " has the wrong number of values");
  }
  return *this;
}

BatchInsert& BatchInsert::put(Cell cell) {
  cells_.push_back(std::move(cell));
  return *this;
}

BatchInsert& BatchInsert::add(const nlohmann::json& value) {
  return put(value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

BatchInsert& BatchInsert::add(BinaryArray& array) { return put(Encoded{array.take()}); }

BatchInsert::~BatchInsert() = default;

void BatchInsert::flush() { write(true); }
void BatchInsert::send() { write(false); }

void BatchInsert::write(bool end) {
  if (cells_.size() % columns_.size() != 0) {
    throw std::logic_error("BatchInsert: a row of " + table_ + " has the wrong number of values");
  }
  if (db_->engine() == Engine::Postgres) {
    sendPostgres(end);
  } else if (!cells_.empty()) {
    flushSqlite();
  }
  cells_.clear();
}

std::string BatchInsert::insertSql(size_t rows) const {
  std::string sql = "INSERT INTO " + table_ + " (";
  std::string tuple = "(";
  for (size_t c = 0; c < columns_.size(); ++c) {
    sql += (c ? ", " : "") + columns_[c];
    tuple += c ? ", ?" : "?";
  }
  tuple += ")";
  sql += ") VALUES ";
  sql.reserve(sql.size() + rows * (tuple.size() + 2));
  for (size_t r = 0; r < rows; ++r) sql += (r ? ", " : "") + tuple;
  return sql;
}

void BatchInsert::flushSqlite() {
  const size_t width = columns_.size();
  const size_t total = rows();
  for (size_t first = 0; first < total; first += kSqliteRowsPerStatement) {
    size_t count = std::min(kSqliteRowsPerStatement, total - first);
    std::optional<Statement> partial;
    Statement* insert = nullptr;
    if (count == kSqliteRowsPerStatement) {
      if (!full_) full_.emplace(db_, insertSql(count));
      insert = &*full_;
      insert->reset();
    } else {
      partial.emplace(db_, insertSql(count));
      insert = &*partial;
    }
    int index = 1;
    for (size_t k = first * width; k < (first + count) * width; ++k, ++index) {
      std::visit(
          [&](const auto& value) {
            if constexpr (std::is_same_v<std::decay_t<decltype(value)>, Encoded>) {
              throw std::logic_error("BatchInsert: an array of " + table_ + " is for PostgreSQL's binary COPY");
            } else {
              insert->bind(index, value);
            }
          },
          cells_[k]);
    }
    insert->run();
  }
}

std::string BatchInsert::copyStatement() const {
  std::string copy = "COPY " + table_ + " (";
  for (size_t c = 0; c < columns_.size(); ++c) copy += (c ? ", " : "") + columns_[c];
  return copy + (format_ == Format::kBinary ? ") FROM STDIN WITH (FORMAT binary)" : ") FROM STDIN");
}

std::string BatchInsert::take() {
  if (cells_.size() % columns_.size() != 0) {
    throw std::logic_error("BatchInsert: a row of " + table_ + " has the wrong number of values");
  }
  std::string data;
  if (format_ == Format::kBinary) {
    appendBinary(data);
  } else {
    appendText(data);
  }
  cells_.clear();
  return data;
}

void BatchInsert::sendPostgres(bool end) {
  if (!cells_.empty()) copy_.send(take());
  if (end) copy_.finish();
}

void BatchInsert::appendText(std::string& data) const {
  const size_t width = columns_.size();
  for (size_t k = 0; k < cells_.size(); ++k) {
    const Cell& cell = cells_[k];
    if (std::holds_alternative<std::nullptr_t>(cell)) {
      data += "\\N";
    } else if (const auto* i = std::get_if<int64_t>(&cell)) {
      data += std::to_string(*i);
    } else if (const auto* d = std::get_if<double>(&cell)) {
      appendPostgresDouble(data, *d);
    } else if (const auto* text = std::get_if<std::string>(&cell)) {
      appendCopyText(data, *text);
    } else if (const auto* bytes = std::get_if<std::span<const uint8_t>>(&cell)) {
      appendCopyBytea(data, *bytes);
    } else {
      throw std::logic_error("BatchInsert: an array of " + table_ + " needs the binary format");
    }
    data += (k + 1) % width == 0 ? '\n' : '\t';
  }
}

void BatchInsert::appendBinary(std::string& data) const {
  const size_t width = columns_.size();
  for (size_t k = 0; k < cells_.size(); ++k) {
    if (k % width == 0) appendBig16(data, static_cast<uint16_t>(width));
    const Cell& cell = cells_[k];
    if (std::holds_alternative<std::nullptr_t>(cell)) {
      appendBig32(data, 0xffffffffu);  // -1: NULL
    } else if (const auto* i = std::get_if<int64_t>(&cell)) {
      appendBig32(data, 8);
      appendBig64(data, static_cast<uint64_t>(*i));
    } else if (const auto* d = std::get_if<double>(&cell)) {
      appendBig32(data, 8);
      appendBig64(data, std::bit_cast<uint64_t>(*d));
    } else if (const auto* text = std::get_if<std::string>(&cell)) {
      appendField(data, *text);
    } else if (const auto* bytes = std::get_if<std::span<const uint8_t>>(&cell)) {
      appendField(data, std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()));
    } else {
      appendField(data, std::get<Encoded>(cell).bytes);
    }
  }
}

BinaryArray& BinaryArray::add(std::string_view text) {
  if (of_ != Of::kText) throw std::logic_error("BinaryArray: text in an array of doubles");
  appendField(elements_, text);
  ++count_;
  return *this;
}

BinaryArray& BinaryArray::add(double value) {
  if (of_ != Of::kFloat8) throw std::logic_error("BinaryArray: a double in an array of text");
  appendBig32(elements_, 8);
  appendBig64(elements_, std::bit_cast<uint64_t>(value));
  ++count_;
  return *this;
}

BinaryArray& BinaryArray::add(std::nullptr_t) {
  appendBig32(elements_, 0xffffffffu);
  nulls_ = true;
  ++count_;
  return *this;
}

BinaryArray& BinaryArray::add(const nlohmann::json& value) {
  return add(std::string_view(value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)));
}

std::string BinaryArray::take() {
  // pg_type's oids of text and double precision, fixed since PostgreSQL's first releases.
  constexpr uint32_t kTextOid = 25, kFloat8Oid = 701;
  std::string out;
  out.reserve(20 + elements_.size());
  appendBig32(out, count_ ? 1 : 0);  // dimensions: an empty array has none
  appendBig32(out, nulls_ ? 1 : 0);
  appendBig32(out, of_ == Of::kText ? kTextOid : kFloat8Oid);
  if (count_) {
    appendBig32(out, static_cast<uint32_t>(count_));
    appendBig32(out, 1);  // the lower bound
  }
  out += elements_;
  elements_.clear();
  count_ = 0;
  nulls_ = false;
  return out;
}

std::vector<std::vector<int64_t>> reserveIds(Connection* db,
                                             std::span<const std::pair<std::string_view, size_t>> tables) {
  std::vector<std::vector<int64_t>> ids(tables.size());
  if (db->engine() == Engine::Postgres) {
    // One statement for every table. nextval is outside transactions:
    // concurrent ingests never get the same id. A sequence that increments
    // by more than 1 (migration 0014) hands out blocks: the value nextval
    // returns and the increment - 1 ids after it are this caller's alone.
    std::string sql;
    for (size_t t = 0; t < tables.size(); ++t) {
      std::string name = std::to_string(2 * t + 1), count = std::to_string(2 * t + 2);
      sql += (t ? " UNION ALL " : "") + std::string("SELECT ") + std::to_string(t) +
             " AS k, nextval(q.seqrelid), q.seqincrement FROM pg_sequence q CROSS JOIN generate_series(1, (?" +
             count + "::bigint + q.seqincrement - 1) / q.seqincrement) WHERE q.seqrelid = pg_get_serial_sequence(?" +
             name + ", 'id')::regclass";
    }
    Statement next(db, sql);
    for (size_t t = 0; t < tables.size(); ++t) {
      next.bind(static_cast<int>(2 * t + 1), tables[t].first)
          .bind(static_cast<int>(2 * t + 2), static_cast<int64_t>(tables[t].second));
    }
    while (next.step()) {
      size_t t = static_cast<size_t>(next.getInt(0));
      auto& list = ids.at(t);
      for (int64_t id = next.getInt(1), end = id + next.getInt(2); id < end && list.size() < tables[t].second; ++id) {
        list.push_back(id);
      }
    }
    for (size_t t = 0; t < tables.size(); ++t) {
      std::sort(ids[t].begin(), ids[t].end());
      if (ids[t].size() != tables[t].second)
        throw DbError(0, "", "PostgreSQL: reserving ids of " + std::string(tables[t].first) + " failed");
    }
    return ids;
  }
  for (size_t t = 0; t < tables.size(); ++t) {
    if (tables[t].second == 0) continue;
    Statement largest(db, "SELECT COALESCE(MAX(id), 0) FROM " + std::string(tables[t].first));
    int64_t last = largest.step() ? largest.getInt(0) : 0;
    largest.run();
    ids[t].reserve(tables[t].second);
    for (size_t k = 1; k <= tables[t].second; ++k) ids[t].push_back(last + static_cast<int64_t>(k));
  }
  return ids;
}

}  // namespace tally::store::detail

// A run's passes and counters averaged over its samples (Runs::passes,
// Runs::detail): the pass rows of the run read in one statement and summed
// here. On PostgreSQL a pass's counters are arrays on its row (0012), read
// whole as array text: summing them in SQL unnested every array into rows
// and hashed them, 0.76 ms of the server's time per run of 40 passes at 1M
// samples against 0.14 ms to send the rows (docs/benchmarks.md, "A run in
// one transaction"). SQLite reads its counters table joined to the passes.
#include <algorithm>
#include <charconv>
#include <map>
#include <stdexcept>
#include <tuple>

#include "store/internal.hpp"

namespace tally::store::detail {
namespace {

// The elements of a one-dimensional PostgreSQL array in its text form
// ("{a,\"b c\",NULL}"): unquoted NULL is absent; quoted elements lose their
// quotes and backslashes. The arrays read here are the store's own, checked
// one-dimensional by 0012's constraint; anything else is a DbError.
std::vector<std::optional<std::string>> arrayElements(std::string_view text) {
  auto bad = [&]() { return DbError(0, "XX000", "PostgreSQL: not a one-dimensional array: " + std::string(text.substr(0, 80))); };
  if (text.size() < 2 || text.front() != '{' || text.back() != '}') throw bad();
  std::vector<std::optional<std::string>> out;
  size_t i = 1;
  const size_t end = text.size() - 1;
  if (i == end) return out;
  while (true) {
    if (i >= end) throw bad();
    if (text[i] == '"') {
      std::string element;
      for (++i;; ++i) {
        if (i >= end) throw bad();
        if (text[i] == '\\') {
          if (++i >= end) throw bad();
          element += text[i];
        } else if (text[i] == '"') {
          ++i;
          break;
        } else {
          element += text[i];
        }
      }
      out.emplace_back(std::move(element));
    } else {
      size_t stop = text.find(',', i);
      if (stop == std::string_view::npos || stop > end) stop = end;
      std::string_view element = text.substr(i, stop - i);
      if (element.empty() || element.find_first_of("{}\"") != std::string_view::npos) throw bad();
      if (element == "NULL") {
        out.emplace_back(std::nullopt);
      } else {
        out.emplace_back(std::string(element));
      }
      i = stop;
    }
    if (i == end) return out;
    if (text[i] != ',') throw bad();
    ++i;
  }
}

std::optional<double> number(const std::optional<std::string>& text) {
  if (!text) return std::nullopt;
  double value = 0;
  auto [end, ec] = std::from_chars(text->data(), text->data() + text->size(), value);
  if (ec != std::errc() || end != text->data() + text->size()) {
    throw DbError(0, "XX000", "PostgreSQL: not a number in a counter array: " + *text);
  }
  return value;
}

const std::string& required(const std::optional<std::string>& text) {
  if (!text) throw DbError(0, "XX000", "PostgreSQL: NULL in a counter array that holds none");
  return *text;
}

// A sum that stays absent until a value is added, as SQL's SUM of NULLs.
void add(std::optional<double>& sum, std::optional<double> value) {
  if (value) sum = sum.value_or(0) + *value;
}

// MIN over text, NULLs ignored; byte order, as both engines compare these
// columns (COLLATE "C" on PostgreSQL, BINARY on SQLite).
void least(std::optional<std::string>& min, std::optional<std::string> value) {
  if (value && (!min || *value < *min)) min = std::move(value);
}

struct CounterInput {
  std::string resource;
  std::optional<std::string> kind, format;
  std::string access;
  double count = 0, bytes = 0;
  std::string source;
  std::optional<double> footprint;
};

struct CounterSums {
  CounterInput sums;  // kind and format: the least; count, bytes, footprint: summed
  int64_t passPosition = 0, position = 0;  // the least of each: the counters' order
  size_t seen = 0;                         // first seen, for ties
};

struct PassSums {
  int64_t position = 0;  // the least: the passes' order
  double gpuMs = 0;
  std::optional<double> gpuMsInstrumented, fragmentInvocations, fragmentInvocationsStatistic;
  double ratioSum = 0;
  int ratios = 0;
  std::map<std::tuple<std::string, std::string, std::string>, CounterSums> counters;
};

class Summer {
 public:
  PassSums& pass(const std::string& name, int64_t position) {
    auto [it, added] = passes_.try_emplace(name);
    it->second.position = added ? position : std::min(it->second.position, position);
    return it->second;
  }
  static void addPass(PassSums& p, RowReader& row) {
    p.gpuMs += row.getDouble();
    add(p.gpuMsInstrumented, row.getOptDouble());
    if (auto ratio = row.getOptDouble()) {
      p.ratioSum += *ratio;
      ++p.ratios;
    }
    add(p.fragmentInvocations, row.getOptDouble());
    add(p.fragmentInvocationsStatistic, row.getOptDouble());
  }
  void addCounter(PassSums& p, int64_t passPosition, int64_t position, CounterInput c) {
    auto [it, added] = p.counters.try_emplace(std::tuple(c.resource, c.access, c.source));
    CounterSums& s = it->second;
    if (added) {
      s.sums = CounterInput{c.resource, std::nullopt, std::nullopt, c.access, 0, 0, c.source, std::nullopt};
      s.passPosition = passPosition;
      s.position = position;
      s.seen = seen_++;
    }
    least(s.sums.kind, std::move(c.kind));
    least(s.sums.format, std::move(c.format));
    s.sums.count += c.count;
    s.sums.bytes += c.bytes;
    add(s.sums.footprint, c.footprint);
    s.passPosition = std::min(s.passPosition, passPosition);
    s.position = std::min(s.position, position);
  }

  // Per frame: sums over `samples`, a sample without a pass or counter
  // counting as 0; the overhead ratio is the mean of the samples that have
  // one. Passes by their least position, then name; a pass's counters by
  // their pass's least position, then their own, then first seen.
  std::vector<Pass> result(int samples) const {
    auto mean = [samples](std::optional<double> sum) { return sum ? std::optional(*sum / samples) : sum; };
    // The map holds them by name: a stable sort by position keeps names in order.
    std::vector<const std::pair<const std::string, PassSums>*> order;
    for (const auto& entry : passes_) order.push_back(&entry);
    std::stable_sort(order.begin(), order.end(),
                     [](const auto* a, const auto* b) { return a->second.position < b->second.position; });
    std::vector<Pass> out;
    for (const auto* entry : order) {
      const PassSums* p = &entry->second;
      Pass pass{entry->first,
                p->gpuMs / samples,
                nullptr,
                mean(p->gpuMsInstrumented),
                p->ratios ? std::optional(p->ratioSum / p->ratios) : std::nullopt,
                mean(p->fragmentInvocations),
                mean(p->fragmentInvocationsStatistic),
                {}};
      std::vector<const CounterSums*> counters;
      for (const auto& [key, c] : p->counters) counters.push_back(&c);
      std::sort(counters.begin(), counters.end(), [](const CounterSums* a, const CounterSums* b) {
        return std::tie(a->passPosition, a->position, a->seen) < std::tie(b->passPosition, b->position, b->seen);
      });
      for (const CounterSums* c : counters) {
        const CounterInput& s = c->sums;
        pass.counters.push_back(Counter{s.resource, s.kind, s.format, s.access, s.count / samples,
                                        s.bytes / samples, nullptr, s.source, mean(s.footprint)});
      }
      out.push_back(std::move(pass));
    }
    return out;
  }

 private:
  std::map<std::string, PassSums> passes_;
  size_t seen_ = 0;
};

constexpr const char* kPassColumns =
    "p.name, p.position, p.gpu_ms, p.gpu_ms_instrumented, p.overhead_ratio, p.fragment_invocations, "
    "p.fragment_invocations_statistic";

void readPostgres(Connection* db, int64_t runId, Summer& summer) {
  Statement rows(db, std::string("SELECT ") + kPassColumns +
                         ", p.counter_resources, p.counter_kinds, p.counter_formats, p.counter_accesses, "
                         "p.counter_counts, p.counter_bytes, p.counter_sources, p.counter_footprints "
                         "FROM samples s JOIN passes p ON p.sample_id = s.id WHERE s.run_id = ?1 "
                         "ORDER BY s.camera_index, p.position");
  rows.bind(1, runId);
  while (rows.step()) {
    RowReader row(rows);
    std::string name = row.getText();
    int64_t position = row.getInt();
    PassSums& pass = summer.pass(name, position);
    Summer::addPass(pass, row);
    auto resources = arrayElements(row.getText()), kinds = arrayElements(row.getText()),
         formats = arrayElements(row.getText()), accesses = arrayElements(row.getText()),
         counts = arrayElements(row.getText()), bytes = arrayElements(row.getText()),
         sources = arrayElements(row.getText()), footprints = arrayElements(row.getText());
    row.end();
    const size_t n = resources.size();
    for (const auto* a : {&kinds, &formats, &accesses, &counts, &bytes, &sources, &footprints}) {
      if (a->size() != n) throw DbError(0, "XX000", "PostgreSQL: a pass's counter arrays differ in length");
    }
    for (size_t k = 0; k < n; ++k) {
      summer.addCounter(pass, position, static_cast<int64_t>(k),
                        CounterInput{required(resources[k]), std::move(kinds[k]), std::move(formats[k]),
                                     required(accesses[k]), *number(required(counts[k])),
                                     *number(required(bytes[k])), required(sources[k]), number(footprints[k])});
    }
  }
}

void readSqlite(Connection* db, int64_t runId, Summer& summer) {
  // One row per counter, and one with NULL counter columns for a pass
  // without counters.
  Statement rows(db, std::string("SELECT p.id, ") + kPassColumns +
                         ", c.position, c.resource, c.kind, c.format, c.access, c.count, c.bytes, c.source, "
                         "c.footprint_bytes FROM samples s JOIN passes p ON p.sample_id = s.id "
                         "LEFT JOIN counters c ON c.pass_id = p.id WHERE s.run_id = ?1 "
                         "ORDER BY s.camera_index, p.position, c.position");
  rows.bind(1, runId);
  std::optional<int64_t> current;
  PassSums* pass = nullptr;
  while (rows.step()) {
    RowReader row(rows);
    int64_t id = row.getInt();  // one pass's rows follow each other
    std::string name = row.getText();
    int64_t position = row.getInt();
    if (id != current) {
      current = id;
      pass = &summer.pass(name, position);
      Summer::addPass(*pass, row);
    } else {
      for (int i = 0; i < 5; ++i) row.getOptDouble();  // the pass's sums, taken at its first row
    }
    if (row.isNull()) {  // no counter
      for (int i = 0; i < 9; ++i) row.getOptText();
      row.end();
      continue;
    }
    int64_t counterPosition = row.getInt();
    CounterInput c{row.getText(),   row.getOptText(), row.getOptText(), row.getText(),
                   row.getDouble(), row.getDouble(),  row.getText(),    row.getOptDouble()};
    row.end();
    summer.addCounter(*pass, position, counterPosition, std::move(c));
  }
}

}  // namespace

std::vector<Pass> readRunPasses(Connection* db, int64_t runId, int samples) {
  if (samples == 0) return {};
  Summer summer;
  if (db->engine() == Engine::Postgres) {
    readPostgres(db, runId, summer);
  } else {
    readSqlite(db, runId, summer);
  }
  return summer.result(samples);
}

}  // namespace tally::store::detail

#include "command_support.hpp"

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace tally::client {

int fail(Io& io, const std::string& message) {
  io.err << "tally: " << message << '\n';
  return 1;
}

void printJson(Io& io, const json& j) { io.out << j.dump(2) << '\n'; }

// A listing (`tally runs`, `tally sweeps`): the response as JSON, or a table
// of one row per item and a hint on stderr when a page was cut short.
int printListing(Io& io, const Result<json>& res, bool all, const std::string& noun,
                 std::vector<Table::Column> columns,
                 const std::function<void(const json& page, Table& table)>& addRows) {
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  Table t(std::move(columns));
  addRows(*res, t);
  t.print(io.out, io.colour);
  if (!all && !nextCursor(*res).empty()) io.err << "more " << noun << ": add --all, or --limit N\n";
  return 0;
}

std::string size(const RunView& r) {
  if (!r.width || !r.height) return kMissing;
  return std::to_string(*r.width) + "x" + std::to_string(*r.height);
}

std::string orMissing(const std::string& s) { return s.empty() ? kMissing : s; }

std::string progressCell(const JobView& j) {
  if (j.done && j.total) return std::to_string(*j.done) + "/" + std::to_string(*j.total);
  return j.fraction ? percent(j.fraction) : kMissing;
}

// "1/3": attempts so far of the most it gets; "1" from a server that gives no maximum.
std::string attemptsCell(const JobView& j) {
  if (!j.attempts) return kMissing;
  return std::to_string(*j.attempts) + (j.maxAttempts ? "/" + std::to_string(*j.maxAttempts) : "");
}

}  // namespace tally::client

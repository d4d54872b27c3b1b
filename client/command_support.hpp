// What the subcommands' files share: failing with a message, printing JSON or
// a listing, and the cells several tables show.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "tables.hpp"

namespace tally::client {

int fail(Io& io, const std::string& message);
void printJson(Io& io, const json& j);
// A listing (`tally runs`, `tally sweeps`): the response as JSON, or a table
// of one row per item and a hint on stderr when a page was cut short.
int printListing(Io& io, const Result<json>& res, bool all, const std::string& noun,
                 std::vector<Table::Column> columns,
                 const std::function<void(const json& page, Table& table)>& addRows);
std::string size(const RunView& r);
std::string orMissing(const std::string& s);
std::string progressCell(const JobView& j);
// "1/3": attempts so far of the most it gets; "1" from a server that gives no maximum.
std::string attemptsCell(const JobView& j);

}  // namespace tally::client

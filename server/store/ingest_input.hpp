// What the ingest's files share to read a result (ingest.cpp, sweep_frame.cpp):
// bad input throws IngestError naming the JSON path, and the ingest's
// transaction then rolls back.
#pragma once

#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "common/json_fields.hpp"

namespace tally::store::detail {

struct IngestError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] inline void bad(const std::string& path, const std::string& what) {
  throw IngestError(path + ": " + what);
}

// Members of the result: a fault throws IngestError naming the path.
inline constexpr json_fields::Members kMembers{[](const Error& error) { throw IngestError(error.text()); }};

// A sweep result's frame (docs/result-schema.md, "Sweep results"): what the
// sweeps list and the dashboard's charts rely on, whatever the sweep.
// Throws IngestError naming the first bad field.
void checkSweep(const nlohmann::json& result);

}  // namespace tally::store::detail

// Stored runs as the accuracy and repeatability routes read them: every run a
// filter selects (bounded), and a run's configuration in the form the shared
// computations (analysis/accuracy, analysis/repeats) compare.
#pragma once

#include <vector>

#include "analysis/run_config.hpp"
#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::reports {

// Every run the filter selects, oldest first, at most maxRuns (a multiple of
// 1000, the page size); `complete` is false when more matched.
Result<std::vector<store::RunRow>> selectRuns(store::Store& store, const store::RunFilter& filter, int maxRuns,
                                              bool& complete);

// The run's configuration; its device is the device id (names may repeat).
analysis::RunConfig runConfigOf(const store::RunRow& row);

// One stored counter line: "pass/resource access", as analysis::lineKey names a result's.
std::string lineKey(const std::string& pass, const store::Counter& counter);

}  // namespace tally::reports

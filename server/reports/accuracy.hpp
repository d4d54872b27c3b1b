// GET /api/accuracy: every run counted in a cheaper mode against the exact
// run of the same frames, computed from the stored counters at query time
// with analysis/accuracy (the same code as `tallyd accuracy`).
#pragma once

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::reports {

// Rows for the non-exact runs `filter` selects (oldest first); references are
// looked for among all runs, preferring the same capture. At most
// kAccuracyMaxRuns
// runs are considered; "truncated" says when there were more.
inline constexpr int kAccuracyMaxRuns = 2000;
Result<nlohmann::json> accuracyRows(store::Store& store, const store::RunFilter& filter);

}  // namespace tally::reports

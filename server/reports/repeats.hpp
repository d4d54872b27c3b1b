// GET /api/repeats: groups of runs with one configuration (repeated captures
// of the same spec) and whether they agree within their own noise, computed
// from the stored samples with analysis/repeats (the same code as
// `tallyd repeats`).
#pragma once

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::reports {

// Groups among the runs `filter` selects (oldest first). At most
// kRepeatsMaxRuns runs are considered; "truncated" says when there were more.
inline constexpr int kRepeatsMaxRuns = 2000;
Result<nlohmann::json> repeatGroups(store::Store& store, const store::RunFilter& filter);

}  // namespace tally::reports

// Where in the shader, and in which draw and material, a sample's bytes go
// (migration 0011; docs/api.md, "Sites, draws and shaders"): the routes of
// sites, draws, materials and a run's shader sources, and the top source
// lines per pass that the sample's trace carries. Internal to service/.
#pragma once

#include <map>
#include <vector>

#include "api/router.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace tally::service::detail {

void addSiteRoutes(api::Router& router, ServiceContext& ctx);

// The `top` source lines that move the most bytes, per pass position, for
// the passes with sites; empty when the sample has none.
std::map<int, std::vector<store::SiteRow>> topLinesPerPass(store::Store& store, int64_t sampleId, int top);

}  // namespace tally::service::detail

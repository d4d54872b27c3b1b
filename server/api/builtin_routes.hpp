// Routes that need no store: health, the OpenAPI document, renderer names.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "api/router.hpp"

#include <nlohmann/json.hpp>

namespace tally::api {

// The OpenAPI 3 document (openapi.json in this folder, embedded at build time).
std::string_view openApiDocument();

// GET /api/health, GET /api/openapi.json, and GET /api/renderers when
// rendererNames is not empty (tallyd passes tally::renderers::rendererNames()
// and renderers::optionDefsJson() as `options`, the variant option table;
// the API library does not link the renderers), and renderers::workloadNames()
// as `workloadNames` (the response's "workloads").
//
// storeHealth, when given, is the store's part of /api/health: an object
// whose "status" is "ok" when the store is healthy. Anything else turns the
// answer into a 503 (with Retry-After) whose "status" is "unavailable" and
// whose "store" says why (service/store_health.hpp fills it).
using StoreHealthProbe = std::function<nlohmann::json()>;
void addBuiltinRoutes(Router& router, std::vector<std::string> rendererNames = {},
                      nlohmann::json options = nlohmann::json::array(),
                      std::vector<std::string> workloadNames = {}, StoreHealthProbe storeHealth = {});

}  // namespace tally::api

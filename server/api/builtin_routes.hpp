// Routes that need no store: health, the OpenAPI document, renderer names.
#pragma once

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
void addBuiltinRoutes(Router& router, std::vector<std::string> rendererNames = {},
                      nlohmann::json options = nlohmann::json::array(),
                      std::vector<std::string> workloadNames = {});

}  // namespace tally::api

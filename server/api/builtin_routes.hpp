// Routes that need no store: health, the OpenAPI document, renderer names.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "api/router.hpp"

namespace tally::api {

// The OpenAPI 3 document (openapi.json in this folder, embedded at build time).
std::string_view openApiDocument();

// GET /api/health, GET /api/openapi.json, and GET /api/renderers when
// rendererNames is not empty (tallyd passes tally::renderers::rendererNames();
// the API library does not link the renderers).
void addBuiltinRoutes(Router& router, std::vector<std::string> rendererNames = {});

}  // namespace tally::api

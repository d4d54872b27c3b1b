// Ingest of a result's sites, draws, materials and shader sources
// (ingest_sites.cpp; docs/result-schema.md, "Sites, draws and materials"),
// called by the capture ingest inside its transaction. Bad input throws
// IngestError naming the JSON path, so nothing is half-written.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "store/db.hpp"

namespace tally::store::detail {

// The pass's "sites", "draws", "draws_rest" and "materials", where present.
void insertPassSites(Connection* db, int64_t passId, const nlohmann::json& pass, const std::string& path);

// The run's "shader_sources", where present.
void insertShaderSources(Connection* db, int64_t runId, const nlohmann::json& run, const std::string& path);

// The 64-bit FNV-1a of a text in 16 hex digits, as the result's "shaders" hashes are.
std::string textHash(const std::string& text);

}  // namespace tally::store::detail

// The shader files behind a capture: their hashes (the result's "shaders")
// and the text of those the sites name (a run's "shader_sources").
#pragma once

#include <set>
#include <string>

#include <nlohmann/json.hpp>

namespace tally::capture {

// FNV-1a 64 of every file in the shader folder, by file name.
nlohmann::json shaderHashes();

// The text of each named file of the shader folder (names relative to it;
// absolute names, names with "..", and files that cannot be read are left out).
nlohmann::json shaderSources(const std::set<std::string>& names);

}  // namespace tally::capture

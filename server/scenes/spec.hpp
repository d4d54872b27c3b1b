// Scene specs as they arrive in a capture request: a name or an object.
#pragma once

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "scenes/scene.hpp"

namespace tally::scenes {

// Builds the scene a spec describes:
//   "atrium" | "planes" | "sky"
//   {"name": "atrium"}
//   {"name": "planes", "layers": 8, "order": "back-to-front", "coverage": 1.0}
//   {"name": "sky", "coverage": 0.5}
//   {"gltf": "path/to/scene.gltf", "max_texture_size": 1024}
// Omitted parameters take their defaults (see procedural.hpp); unknown keys
// are errors so a typo is never silently ignored. Errors start with the field
// they concern, relative to the spec ("layers: must be an integer between 1
// and 1024, got \"x\""); the caller prefixes the spec's own place
// ("scenes[2]."). A bare-string spec's error names no field.
Result<Scene> makeScene(const nlohmann::json& spec);

// Checks a spec as makeScene does, with the same errors, without building
// anything: no geometry is made and no file is opened (a glTF path is only
// checked to be a non-empty string; makeScene loads it and reports what is
// wrong with it). Cheap enough for a request thread. Returns the spec in a
// canonical form, every parameter given ({"name": "planes", "layers": 8,
// "order": "back-to-front", "coverage": 1.0}), so that two specs of one
// scene compare equal.
Result<nlohmann::json> checkSceneSpec(const nlohmann::json& spec);

// The same scene's triangles only: a glTF file's images are not decoded
// (GltfOptions::geometryOnly), so its textures have no texels. For CPU work
// on the geometry (heatmap placement, the top-down plan).
Result<Scene> makeSceneGeometry(const nlohmann::json& spec);

}  // namespace tally::scenes

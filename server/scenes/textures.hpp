// Procedural material maps: each material gets all five of the founding
// study's maps (diffuse, ambient, specular, roughness, normal), derived from one
// tileable height function so the maps agree with each other. Deterministic:
// integer hashing only, no std:: random distributions.
#pragma once

#include <cstdint>

#include "scenes/scene.hpp"

namespace tally::scenes {

enum class ProceduralMaterial { Stone, Brick, Tiles, Wood, Fabric, Plaster };
const char* toString(ProceduralMaterial kind);  // "stone", "brick", ...

// 256x256: the size of a typical mid-range game texture mip; large enough that
// mip selection and texture caches behave as with real assets, small enough to
// generate in milliseconds.
constexpr uint32_t kProceduralMapSize = 256;

// Appends the five maps of `kind` to scene.textures and the material to
// scene.materials; returns the material's index.
uint32_t addProceduralMaterial(Scene& scene, ProceduralMaterial kind, uint32_t size = kProceduralMapSize);

// The integer hash behind every procedural texel: deterministic, well mixed
// in all 32 bits, for texel (x, y) of layer or material `seed`.
uint32_t texelHash(uint32_t x, uint32_t y, uint32_t seed);

}  // namespace tally::scenes

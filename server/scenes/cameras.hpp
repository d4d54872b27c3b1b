// Camera sets: the founding study's protocol of 10 viewpoints per scene, with
// at least one mostly sky, one about half sky and one all geometry; and
// explicit camera lists from JSON.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "scenes/bvh.hpp"
#include "scenes/scene.hpp"

namespace tally::scenes {

constexpr int kAutoCameraCount = 10;  // per scene, as in the founding study
// Sky categories (fraction of primary rays that hit no triangle).
constexpr float kMostlySky = 0.7f;  // mostly sky: above this
constexpr float kHalfSkyLo = 0.3f;  // about half sky: within [lo, hi]
constexpr float kHalfSkyHi = 0.7f;
constexpr float kAllGeometry = 0.02f;  // all geometry: below this
// The CPU estimate's default grid and aspect: 96x54 rays at 16:9, the aspect
// of four of the study's five resolutions; one ray per 20x20 pixels at 1080p.
constexpr int kSkyRaysX = 96;
constexpr int kSkyRaysY = 54;
constexpr float kSkyAspect = 16.0f / 9.0f;

// Fraction of a raysX x raysY grid of primary rays (through pixel centres of a
// viewport of the given aspect, camera as in viewMatrix(), vertical fovDeg)
// that hit no triangle as the renderers draw it: either side of a
// double-sided triangle, the front only of a single-sided one (its back face
// is culled, and the ray goes on). Rays are unbounded: a renderer must put
// its far plane beyond the scene bounds to match. Alpha-masked texels count as
// geometry. The renderer later measures the exact fraction from its stencil.
float skyFraction(const Bvh& bvh, const Camera& camera, float aspect = kSkyAspect, int raysX = kSkyRaysX,
                  int raysY = kSkyRaysY);
// Builds a BVH first: for one-off calls; use the Bvh overload in loops.
float skyFraction(const Scene& scene, const Camera& camera, float aspect = kSkyAspect, int raysX = kSkyRaysX,
                  int raysY = kSkyRaysY);

// kAutoCameraCount deterministic viewpoints chosen from the scene's bounds,
// each with skyFraction measured (96x54 rays, 16:9) and a label naming its sky
// category and placement. Scenes with fixed cameras (planes, sky) start with
// them and add rotations about the same eye, which keep stacked planes exactly
// coincident on screen (overdraw per covered pixel stays `layers`) while
// changing the covered fraction; the three categories are met where the
// scene's geometry allows (the sky scene's quad spans less than the field of
// view vertically, so it has no all-geometry view).
// Flat or thin scenes (smallest extent under 5% of the largest): views from
// outside, off the scene's plane. Other scenes: eyes on a grid inside the bounds that are in open space, 8
// yaws x 7 pitches each, screened with a coarse ray grid, then one camera per
// category and the rest spread over sky-fraction bins, then position and
// direction. When no grid eye is in open space (a closed object), views from
// outside the bounds instead. Every camera of a scene with triangles sees
// some of them as drawn (full-grid sky fraction below 1; a single-sided
// triangle only from its front): one that would not is replaced by the
// unchosen candidate that sees the most, or dropped when none sees any.
// Empty for a scene without triangles.
std::vector<Camera> autoCameras(const Scene& scene);

// An explicit list: [{"eye":[x,y,z], "target":[x,y,z], "fov_deg":60,
// "label":"...", "sky_fraction":0.5}, ...]; fov_deg, label, sky_fraction are
// optional. Errors name the element and field relative to the array:
// "[2].eye: must be an array of 3 finite numbers, got [1,2]".
Result<std::vector<Camera>> camerasFromJson(const nlohmann::json& cameras);

}  // namespace tally::scenes

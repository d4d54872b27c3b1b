// What a renderer configuration cannot draw, known from the scene and the
// options alone: checked by the capture runner for every (renderer, scene)
// pair before any GPU work, and again by each renderer's setup.
#pragma once

#include <string>
#include <string_view>

#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::renderers {

// Why `renderer` with `options` cannot draw `scene` ("" when it can), naming
// the renderer and the limit:
// - the visibility buffers' id: at most shaders::kMaxDraws draws (meshes)
//   and kTriangleIdMask triangles per draw;
// - glTF features a variant does not carry (alpha blend with msaa, alpha
//   mask with output=overdraw, deferred's emission with gbuffer=subpass,
//   shading=compute or msaa).
std::string sceneRefusal(std::string_view renderer, const scenes::Scene& scene, const RendererOptions& options);
// The feature part alone, from the scene's features (renderer setup).
std::string featureRefusal(std::string_view renderer, const scenes::Scene::Features& features,
                           const RendererOptions& options);

}  // namespace tally::renderers

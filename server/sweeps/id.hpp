// Sweep "id-capacity": the visibility buffers pack the draw and the triangle
// within it into one 32-bit id (shared.h: 9 bits of draw, 23 of triangle, the
// all-ones id the clear value). This sweep grows the draw count and the
// triangles per draw across those limits and checks, per renderer and point,
// that the renderer either refuses the scene with a reason naming the limit
// and the scene's count, or renders ids that name exactly the triangle that
// covers each pixel centre: the ids read back are decoded from the documented
// bit layout and compared with a CPU rasterisation of the same geometry. For
// refused points it states what the refusal prevents: how many triangles
// would share an id had they been packed anyway (docs/measurement.md, "Sweep:
// visibility-buffer id capacity").
//
// The scene of a point: `draws` meshes of `triangles_per_draw` triangles each,
// one material. All but the last few triangles of each mesh are degenerate
// (three times one vertex: they rasterise nothing), so the ids on screen are
// the highest of each draw; the last ones tile a plane facing the camera, one
// tile per draw, with edges on pixel boundaries so no pixel centre is in doubt.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "sweeps/options.hpp"
#include "common/resolution.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"
#include "scenes/scene.hpp"

namespace tally::sweeps {

inline constexpr std::string_view kIdSweepName = "id-capacity";
inline constexpr size_t kMaxIdSweepAxis = 16;       // values per axis (draws, triangles_per_draw)
inline constexpr uint64_t kMaxIdSweepDraws = 4096;  // 8x the id's 512: the draw axis past its limit
// Triangles one point builds (draws x triangles_per_draw): two draws one over
// the per-draw limit of 8,388,607. At 12 bytes of indices each that is 192 MiB
// of index buffer, held about four times over while uploading.
inline constexpr uint64_t kMaxIdSweepTriangles = uint64_t{1} << 24;
// The visible triangles at the end of each draw, and the tile they fill:
// two strips of 2 x 3 pixels, each split along its diagonal into two
// triangles of 3 pixel centres. A diagonal from (0, 0) to (2, 3) meets no
// pixel centre (k + 0.5, l + 0.5): (2k + 1) 3 is odd, (2l + 1) 2 even.
inline constexpr uint32_t kIdVisibleTriangles = 4;
inline constexpr uint32_t kIdTileWidth = 4, kIdTileHeight = 3;  // pixels

struct IdSweepSpec {
  std::vector<std::string> renderers = {"visbuffer", "visbuffer-lean"};
  std::vector<uint64_t> draws;
  std::vector<uint64_t> trianglesPerDraw;
  // 32 x 32 tiles: every draw up to 1024 gets a tile.
  Resolution resolution = {kIdTileWidth * 32, kIdTileHeight * 32};
  uint64_t wrongPixels = 0;  // threshold: a point fails when refused or with more wrong pixels
  nlohmann::json source;
};

// The renderers with a visibility id: "visbuffer", "visbuffer-lean".
std::vector<std::string> idCapacityRenderers();

Result<IdSweepSpec> parseIdSweepSpec(const nlohmann::json& spec,
                                     const std::vector<std::string>& knownRenderers);

// Whether `draws` draws of `trianglesPerDraw` triangles fit the id (shared.h):
// draws <= 2^9 and triangles <= 2^23 - 1, so the clear value stays free.
bool idFits(uint64_t draws, uint64_t trianglesPerDraw);

// The layout the ids are decoded with: draw = id >> triangleBits, triangle =
// id & (2^triangleBits - 1), 0xffffffff = nothing drawn. The sweep uses
// shared.h's 23 bits; a test decodes with a wrong width to see the check fail.
struct IdLayout {
  uint32_t triangleBits = 23;  // 1..31
  constexpr uint32_t draw(uint32_t id) const { return id >> triangleBits; }
  constexpr uint32_t triangle(uint32_t id) const { return id & ((1u << triangleBits) - 1u); }
};
inline constexpr uint32_t kIdClear = 0xffffffffu;

// The scene of one point and which draws got a tile. When the resolution
// holds fewer tiles than draws, draw 0 and the highest draws (the ids nearest
// the limit) get them; the other draws are degenerate throughout.
struct IdScene {
  scenes::Scene scene;
  scenes::Camera camera;
  VkExtent2D extent = {};
  uint64_t tiledDraws = 0;
  uint32_t visiblePerDraw = 0;  // min(kIdVisibleTriangles, triangles per draw)
};
IdScene buildIdScene(uint64_t draws, uint64_t trianglesPerDraw, VkExtent2D extent);

// Per pixel (top row first), the triangle whose interior holds the pixel
// centre, from the scene's vertices projected on the CPU (double); drawn
// nowhere: draw == kNone. Pixels whose centre lies within 1/1000 pixel of an
// edge, or inside two triangles, are ambiguous and not checked.
struct IdCoverage {
  static constexpr uint32_t kNone = 0xffffffffu;
  std::vector<uint32_t> draw, triangle;
  std::vector<bool> ambiguous;
};
IdCoverage idCoverage(const scenes::Scene& scene, const scenes::Camera& camera, VkExtent2D extent);

struct IdCheck {
  uint64_t checked = 0;  // pixels compared (all but the ambiguous)
  uint64_t ambiguous = 0;
  uint64_t covered = 0;  // of the checked: a triangle covers the centre
  uint64_t wrong = 0;    // decoded id differs from the covering triangle (or from "nothing")
  uint64_t missing = 0;  // of those: covered, but the id is the clear value
  // The largest draw and triangle decoded on pixels found right: the ids
  // nearest the limit that the frame showed (0 when none was right).
  uint32_t highestDraw = 0, highestTriangle = 0;
  nlohmann::json examples = nlohmann::json::array();  // the first few wrong pixels
  nlohmann::json toJson() const;
};
// `ids`: one per pixel, as read back from the visibility target.
IdCheck checkIds(std::span<const uint32_t> ids, const IdCoverage& truth, VkExtent2D extent,
                 const IdLayout& layout = {});

// The first 32-bit word of every texel of a visibility target read back
// (R32_UINT or R32G32_UINT): the id. Empty when the size is not pixels x 4 or x 8.
std::vector<uint32_t> idsOf(std::span<const uint8_t> targetBytes, uint64_t pixels);

// Were `draws` x `trianglesPerDraw` packed anyway, as packVisibilityId does
// (the draw shifted out of 32 bits, the triangle masked): how many draws share
// a draw id, how many triangles of a draw share a triangle id, how many
// triangles in all share their id with another or with the clear value, and
// what the last triangle of the last draw would decode as.
nlohmann::json wouldAlias(uint64_t draws, uint64_t trianglesPerDraw);

Result<nlohmann::json> runIdSweep(gpu::Context& ctx, const IdSweepSpec& spec, const SweepOptions& options);

}  // namespace tally::sweeps

// atrium: the default scene, a Sponza-like court built from the fewest
// triangles that still give what the study measures in Sponza:
// - overshading depth: banners in front of two storeys of arcades, with
//   columns and galleries behind them, stack several surfaces behind many
//   pixels;
// - sky fraction: the court is open to the sky, so cameras range from all
//   geometry (galleries, floor) to mostly sky (looking up from the court);
// - material count: six materials (stone, brick, floor tiles, wood, fabric,
//   plaster), each with all five maps, so binding and reading every map is
//   exercised as with Sponza's 25 materials;
// - triangle size: large floor and wall quads next to small column facets.
// Counts: columns are 10-sided prisms with box plinths and capitals (40
// triangles each, 36 columns: 1,440), arches have 6 segments (30 triangles
// per bay, 32 bays: 960), banners 8 segments (8 x 16 = 128), and the floor,
// walls, slabs, parapets and doors are single quads and boxes (90): 2,618
// triangles. Fewer column sides would read as boxes and fewer arch segments
// as gables; more would add triangles that no measurement needs.
// Units are metres; the court runs along X, Y is up.
#include <cmath>

#include "scenes/mesh_builder.hpp"
#include "scenes/procedural.hpp"
#include "scenes/textures.hpp"

namespace tally::scenes {
namespace {

constexpr float kPi = 3.14159265358979f;

constexpr float kHalfLength = 12.0f;  // end walls at x = +-12
constexpr float kArcadeZ = 5.0f;      // arcade wall centre plane at z = +-5
constexpr float kArcadeHalfThick = 0.25f;
constexpr float kBackWallZ = 7.5f;  // gallery back walls at z = +-7.5
constexpr float kSlabLipZ = 4.45f;  // floor and roof slabs overhang the arcade to here
constexpr float kBay = 2.5f;        // column spacing
constexpr int kBays = 8;            // columns at x = -10, -7.5, ..., 10
constexpr float kFirstColumnX = -0.5f * kBay * kBays;
constexpr float kColumnRadius = 0.22f;
constexpr int kColumnSides = 10;
constexpr float kBlockHalf = 0.3f;  // plinth and capital half width
constexpr float kBlockHeight = 0.3f;
constexpr float kArchRadius = 0.5f * kBay - kBlockHalf;
constexpr int kArchSegments = 6;  // even: the apex is a vertex
constexpr float kSlabThick = 0.3f;
constexpr float kParapetHeight = 1.0f;

// A storey: floor level, arch springing height, top of the arcade wall.
struct Storey {
  float floor, spring, top;
};
constexpr Storey kStoreys[2] = {{0.0f, 3.0f, 4.6f}, {4.6f + kSlabThick, 7.3f, 8.8f}};
constexpr float kRoofTop = 8.8f + kSlabThick;

// Metres per texture repeat.
constexpr float kStoneTile = 2.0f;
constexpr float kBrickTile = 2.0f;
constexpr float kFloorTile = 2.0f;
constexpr float kWoodTile = 1.0f;
constexpr float kPlasterTile = 4.0f;

const glm::vec3 kX(1, 0, 0), kY(0, 1, 0), kZ(0, 0, 1);

void column(MeshBuilder& b, float x, float z, const Storey& s) {
  const float shaftLo = s.floor + kBlockHeight, shaftHi = s.spring - kBlockHeight;
  // Plinth: sides and top; the bottom rests on the floor.
  b.box({x - kBlockHalf, s.floor, z - kBlockHalf}, {x + kBlockHalf, shaftLo, z + kBlockHalf}, kStoneTile,
        0x3b);
  // Capital: sides and bottom; as thick as the arcade wall, so the wall
  // closes its top.
  b.box({x - kBlockHalf, shaftHi, z - kArcadeHalfThick}, {x + kBlockHalf, s.spring, z + kArcadeHalfThick},
        kStoneTile, 0x37);
  // Shaft: smooth normals, a seam vertex pair so u runs 0..circumference.
  const float circumference = 2.0f * kPi * kColumnRadius;
  uint32_t first = 0;
  for (int i = 0; i <= kColumnSides; ++i) {
    float a = 2.0f * kPi * float(i) / kColumnSides;
    glm::vec3 n(std::cos(a), 0.0f, std::sin(a));
    float u = circumference * float(i) / kColumnSides / kStoneTile;
    uint32_t lo = b.vertex(glm::vec3(x, shaftLo, z) + n * kColumnRadius, n, {u, -shaftLo / kStoneTile});
    b.vertex(glm::vec3(x, shaftHi, z) + n * kColumnRadius, n, {u, -shaftHi / kStoneTile});
    if (i == 0) first = lo;
  }
  for (int i = 0; i < kColumnSides; ++i) {
    uint32_t a = first + 2 * i, c = a + 2;
    float mid = 2.0f * kPi * (float(i) + 0.5f) / kColumnSides;
    glm::vec3 out(std::cos(mid), 0.0f, std::sin(mid));
    b.triangle(a, c, c + 1, out);
    b.triangle(a, c + 1, a + 1, out);
  }
}

// One bay of an arcade wall between column centres x0 and x0 + kBay: the
// spandrel faces on the court and gallery sides and the arch's soffit.
void archBay(MeshBuilder& b, float x0, float side, const Storey& s) {
  const float mid = x0 + 0.5f * kBay;
  const float zCourt = side * (kArcadeZ - kArcadeHalfThick), zGallery = side * (kArcadeZ + kArcadeHalfThick);
  glm::vec2 arch[kArchSegments + 1];  // left springing point, over the top, to the right one
  for (int j = 0; j <= kArchSegments; ++j) {
    float a = kPi * (1.0f - float(j) / kArchSegments);
    arch[j] = {mid + kArchRadius * std::cos(a), s.spring + kArchRadius * std::sin(a)};
  }
  for (float z : {zCourt, zGallery}) {
    glm::vec3 n(0.0f, 0.0f, z == zCourt ? -side : side);
    auto v = [&](glm::vec2 p) {
      glm::vec3 q(p.x, p.y, z);
      return b.vertex(q, n, MeshBuilder::planarUv(q, kX, kY, kStoneTile));
    };
    uint32_t bl = v({x0, s.spring}), tl = v({x0, s.top}), tr = v({x0 + kBay, s.top}),
             br = v({x0 + kBay, s.spring});
    uint32_t p[kArchSegments + 1];
    for (int j = 0; j <= kArchSegments; ++j) p[j] = v(arch[j]);
    // The wall minus the arch opening, fanned from the top corners (every arch
    // point of a half is visible from its corner, so the fan is valid).
    const int half = kArchSegments / 2;
    b.triangle(tl, bl, p[0], n);
    for (int j = 0; j < half; ++j) b.triangle(tl, p[j], p[j + 1], n);
    b.triangle(tl, p[half], tr, n);
    for (int j = half; j < kArchSegments; ++j) b.triangle(tr, p[j], p[j + 1], n);
    b.triangle(tr, p[kArchSegments], br, n);
  }
  // Soffit: normals point down into the opening, u along the arc.
  float arc = 0.0f;
  uint32_t prevCourt = 0, prevGallery = 0;
  for (int j = 0; j <= kArchSegments; ++j) {
    if (j > 0) arc += glm::length(arch[j] - arch[j - 1]);
    glm::vec3 n = glm::normalize(glm::vec3(mid - arch[j].x, s.spring - arch[j].y, 0.0f));
    if (j == 0 || j == kArchSegments) n = glm::vec3(j == 0 ? 1.0f : -1.0f, 0.0f, 0.0f);
    uint32_t c = b.vertex({arch[j].x, arch[j].y, zCourt}, n, {arc / kStoneTile, zCourt / kStoneTile});
    uint32_t g = b.vertex({arch[j].x, arch[j].y, zGallery}, n, {arc / kStoneTile, zGallery / kStoneTile});
    if (j > 0) {
      glm::vec2 m = 0.5f * (arch[j] + arch[j - 1]);
      glm::vec3 inward(mid - m.x, s.spring - m.y, 0.0f);
      b.triangle(prevCourt, c, g, inward);
      b.triangle(prevCourt, g, prevGallery, inward);
    }
    prevCourt = c;
    prevGallery = g;
  }
}

// A banner hanging in front of the upper arcade, gently waved along z.
void banner(MeshBuilder& b, float xMid, float side) {
  constexpr int kSegments = 8;
  constexpr float kWidth = 1.4f, kTop = 8.6f, kBottom = 5.6f, kWave = 0.08f;
  const float z0 = side * 4.3f;
  uint32_t prevTop = 0, prevBottom = 0;
  for (int i = 0; i <= kSegments; ++i) {
    float t = float(i) / kSegments;
    float a = t * 2.0f * kPi;
    float x = xMid - 0.5f * kWidth + kWidth * t;
    float z = z0 + side * kWave * std::sin(a);
    // Normal of the waved strip, facing the court (-side z).
    glm::vec3 n = glm::normalize(glm::vec3(side * kWave * 2.0f * kPi / kWidth * std::cos(a), 0.0f, -side));
    uint32_t top = b.vertex({x, kTop, z}, n, {t, 0.0f});
    uint32_t bottom = b.vertex({x, kBottom, z}, n, {t, 1.0f});
    if (i > 0) {
      glm::vec3 face(0.0f, 0.0f, -side);
      b.triangle(prevTop, prevBottom, bottom, face);
      b.triangle(prevTop, bottom, top, face);
    }
    prevTop = top;
    prevBottom = bottom;
  }
}

}  // namespace

Scene makeAtrium() {
  Scene scene;
  scene.name = "atrium";
  const uint32_t stone = addProceduralMaterial(scene, ProceduralMaterial::Stone);
  const uint32_t brick = addProceduralMaterial(scene, ProceduralMaterial::Brick);
  const uint32_t tiles = addProceduralMaterial(scene, ProceduralMaterial::Tiles);
  const uint32_t wood = addProceduralMaterial(scene, ProceduralMaterial::Wood);
  const uint32_t fabric = addProceduralMaterial(scene, ProceduralMaterial::Fabric);
  const uint32_t plaster = addProceduralMaterial(scene, ProceduralMaterial::Plaster);

  const float L = kHalfLength, B = kBackWallZ, H = kRoofTop;
  const float endPierX = -kFirstColumnX;  // the arcade runs from -10 to 10; solid wall beyond
  MeshBuilder b;

  // Floor: one quad under court and galleries.
  b.quad({-L, 0, -B}, {L, 0, -B}, {L, 0, B}, {-L, 0, B}, kY, kX, -kZ, kFloorTile);
  scene.meshes.push_back(b.finish("floor", tiles));

  // Brick walls, facing inwards: gallery back walls, end walls, and the solid
  // ends of the arcade walls (x beyond the last column), court and gallery side.
  b.quad({-L, 0, -B}, {L, 0, -B}, {L, H, -B}, {-L, H, -B}, kZ, kX, kY, kBrickTile);
  b.quad({-L, 0, B}, {L, 0, B}, {L, H, B}, {-L, H, B}, -kZ, kX, kY, kBrickTile);
  b.quad({-L, 0, -B}, {-L, 0, B}, {-L, H, B}, {-L, H, -B}, kX, kZ, kY, kBrickTile);
  b.quad({L, 0, -B}, {L, 0, B}, {L, H, B}, {L, H, -B}, -kX, kZ, kY, kBrickTile);
  for (float side : {-1.0f, 1.0f}) {
    const float zc = side * (kArcadeZ - kArcadeHalfThick), zg = side * (kArcadeZ + kArcadeHalfThick);
    for (float sx : {-1.0f, 1.0f}) {
      const float x0 = sx * endPierX, x1 = sx * L;
      b.quad({x0, 0, zc}, {x1, 0, zc}, {x1, H, zc}, {x0, H, zc}, {0, 0, -side}, kX, kY, kBrickTile);
      b.quad({x0, 0, zg}, {x1, 0, zg}, {x1, H, zg}, {x0, H, zg}, {0, 0, side}, kX, kY, kBrickTile);
      // The solid end's face towards the arcade openings, under each arch springing.
      for (const Storey& s : kStoreys)
        b.quad({x0, s.floor, zc}, {x0, s.floor, zg}, {x0, s.spring, zg}, {x0, s.spring, zc}, {-sx, 0, 0}, kZ,
               kY, kBrickTile);
    }
  }
  scene.meshes.push_back(b.finish("walls", brick));

  // Arcades: both sides, both storeys.
  for (float side : {-1.0f, 1.0f})
    for (const Storey& s : kStoreys)
      for (int i = 0; i < kBays; ++i) archBay(b, kFirstColumnX + kBay * float(i), side, s);
  scene.meshes.push_back(b.finish("arcades", stone));

  for (float side : {-1.0f, 1.0f})
    for (const Storey& s : kStoreys)
      for (int i = 0; i <= kBays; ++i) column(b, kFirstColumnX + kBay * float(i), side * kArcadeZ, s);
  scene.meshes.push_back(b.finish("columns", stone));

  // Slabs over the galleries: the upper floor and the roof, each with its
  // underside, top and front edge (the court between them is open to the sky).
  for (float side : {-1.0f, 1.0f}) {
    const float zLip = side * kSlabLipZ, zBack = side * B;
    for (float y0 : {kStoreys[0].top, kStoreys[1].top}) {
      const float y1 = y0 + kSlabThick;
      b.quad({-L, y0, zLip}, {L, y0, zLip}, {L, y0, zBack}, {-L, y0, zBack}, -kY, kX, kZ, kPlasterTile);
      b.quad({-L, y1, zLip}, {L, y1, zLip}, {L, y1, zBack}, {-L, y1, zBack}, kY, kX, kZ, kPlasterTile);
      b.quad({-L, y0, zLip}, {L, y0, zLip}, {L, y1, zLip}, {-L, y1, zLip}, {0, 0, -side}, kX, kY,
             kPlasterTile);
    }
  }
  scene.meshes.push_back(b.finish("slabs", plaster));

  // Woodwork: the upper gallery's parapet (a solid rail on the slab lip) and a
  // door in each end wall.
  for (float side : {-1.0f, 1.0f}) {
    const float z0 = side * kSlabLipZ, z1 = side * (kSlabLipZ + 0.1f);
    const float y0 = kStoreys[1].floor, y1 = y0 + kParapetHeight;
    b.box({-endPierX, y0, std::min(z0, z1)}, {endPierX, y1, std::max(z0, z1)}, kWoodTile, 0x3b);
  }
  for (float sx : {-1.0f, 1.0f}) {
    const float x = sx * (L - 0.02f);
    b.quad({x, 0, -1.2f}, {x, 0, 1.2f}, {x, 3.0f, 1.2f}, {x, 3.0f, -1.2f}, {-sx, 0, 0}, kZ, kY, kWoodTile);
  }
  scene.meshes.push_back(b.finish("woodwork", wood));

  for (float side : {-1.0f, 1.0f})
    for (int bay : {1, 3, 4, 6}) banner(b, kFirstColumnX + kBay * (float(bay) + 0.5f), side);
  scene.meshes.push_back(b.finish("banners", fabric));

  updateBounds(scene);
  scene.params = {{"name", "atrium"}};
  return scene;
}

}  // namespace tally::scenes

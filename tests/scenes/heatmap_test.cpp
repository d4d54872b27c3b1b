// Camera heatmap placement (scenes/heatmap.hpp) on scenes whose walkable
// floor is known by construction: a room built here (a floor with a hole, a
// closed pillar, a shelf, a low ceiling, a roof), the procedural atrium, and
// Sponza (when ../shared has it) for the placement on a scene nobody here
// wrote. Also the "heatmap" spec's errors, the sphere layout and the plan.
#include <cmath>
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "strict.hpp"

#include "scenes/bvh.hpp"
#include "scenes/gltf.hpp"
#include "scenes/heatmap.hpp"
#include "scenes/mesh_builder.hpp"
#include "scenes/procedural.hpp"
#include "scenes/spec.hpp"

namespace {
using namespace tally::scenes;
using nlohmann::json;

// The room, 1 m cells over x [0, 20], z [0, 10]:
// - floor (y 0) over x [0, 16]: x above 16 has no surface at all;
// - a closed box pillar x, z [4, 6], y [0.01, 3]: eyes at 1.7 would be inside it,
//   its top (3 m) is off the ground level;
// - a shelf (one quad, y 1.5) over x [8, 10], z [2, 4]: 1.5 m of headroom
//   under it, and its top is off the level;
// - a low ceiling (y 1.9) over x [0, 4], z [0, 2]: too little headroom;
// - a roof (y 4) over x [10, 16]: floor under it, nothing on it;
// - a basement floor (y -3) under x [12, 14], z [6, 8]: the lowest walkable
//   surface there, but off the ground level, so the floor above it is taken.
Scene room() {
  Scene scene;
  scene.name = "room";
  scene.materials.push_back(Material{});
  MeshBuilder b;
  const glm::vec3 up(0, 1, 0), down(0, -1, 0), X(1, 0, 0), Z(0, 0, 1);
  auto level = [&](float x0, float z0, float x1, float z1, float y, const glm::vec3& n) {
    b.quad({x0, y, z0}, {x1, y, z0}, {x1, y, z1}, {x0, y, z1}, n, X, Z, 1.0f);
  };
  level(0, 0, 16, 10, 0.0f, up);
  b.box({4, 0.01f, 4}, {6, 3, 6}, 1.0f);  // 1 cm up: its bottom is not coplanar with the floor
  level(8, 2, 10, 4, 1.5f, up);
  level(0, 0, 4, 2, 1.9f, down);
  level(10, 0, 16, 10, 4.0f, down);
  level(12, 6, 14, 8, -3.0f, up);
  scene.meshes.push_back(b.finish("room", 0));
  updateBounds(scene);
  return scene;
}

HeatmapSpec roomSpec() {
  auto spec = parseHeatmapSpec({{"layout", "floor"}, {"cells", {20, 10}}, {"region", {{0, 0}, {20, 10}}}, {"yaws", 4}});
  EXPECT_TRUE(spec) << spec.error();
  return *spec;
}

// What the room's construction says of a cell centred at (x, z).
std::string expectedRoom(float x, float z) {
  auto in = [&](float x0, float z0, float x1, float z1) { return x > x0 && x < x1 && z > z0 && z < z1; };
  if (x > 16) return kNoSurface;
  if (in(4, 4, 6, 6) || in(8, 2, 10, 4) || in(0, 0, 4, 2)) return "empty";
  return "floor";
}

TEST(HeatmapPlacement, RoomCellsMatchTheFloorBuiltIntoIt) {
  Scene scene = room();
  Bvh bvh = Bvh::build(scene);
  HeatmapSpec spec = roomSpec();
  HeatmapPlacement placed = placeHeatmap(scene, bvh, spec);
  const json& layout = placed.layout;
  ASSERT_EQ(layout["columns"], 20);
  ASSERT_EQ(layout["rows"], 10);
  EXPECT_EQ(layout["ground"], 0.0);
  EXPECT_NEAR(layout["cut_height"].get<double>(), 1.7, 1e-6);
  size_t floors = 0;
  for (int r = 0; r < 10; ++r) {
    for (int c = 0; c < 20; ++c) {
      const float x = c + 0.5f, z = r + 0.5f;
      const json& floor = layout["floor"][r][c];
      const json& empty = layout["empty"][r][c];
      const std::string want = expectedRoom(x, z);
      SCOPED_TRACE("cell " + std::to_string(c) + "," + std::to_string(r));
      if (want == "floor") {
        ASSERT_TRUE(floor.is_number()) << empty;
        EXPECT_NEAR(floor.get<double>(), 0.0, 1e-6);  // under the roof too: never on it
        EXPECT_TRUE(empty.is_null());
        ++floors;
      } else {
        EXPECT_TRUE(floor.is_null()) << floor;
        if (want == kNoSurface) {
          EXPECT_EQ(empty, kNoSurface);
        } else {
          EXPECT_TRUE(empty == kOffLevel || empty == kEyeBlocked || empty == kNoHeadroom) << empty;
        }
      }
    }
  }
  // 16 x 10 cells of floor, less the pillar's 4, the shelf's 4 and the low ceiling's 8.
  EXPECT_EQ(floors, 160u - 4u - 4u - 8u);
  EXPECT_EQ(layout["cells_with_floor"], floors);
  // The pillar's top and the shelf are another level; the ceiling's top too.
  EXPECT_EQ(layout["empty"][4][4], kOffLevel);
  EXPECT_EQ(layout["empty"][2][8], kOffLevel);
  EXPECT_EQ(layout["empty_counts"][kNoSurface], 40);

  // Every pose: eye 1.7 m above its cell's floor at the cell's centre,
  // looking level in yaws 0, 90, 180, 270 degrees; none inside the pillar.
  ASSERT_EQ(placed.poses.size(), floors * 4);
  std::set<std::tuple<uint32_t, uint32_t, uint32_t>> seen;
  for (const auto& p : placed.poses) {
    EXPECT_TRUE(seen.insert({p.column, p.row, p.yaw}).second);
    EXPECT_NEAR(p.camera.eye.x, p.column + 0.5f, 1e-5);
    EXPECT_NEAR(p.camera.eye.z, p.row + 0.5f, 1e-5);
    EXPECT_NEAR(p.camera.eye.y, 1.7f, 1e-5);
    EXPECT_FALSE(p.camera.eye.x > 4 && p.camera.eye.x < 6 && p.camera.eye.z > 4 && p.camera.eye.z < 6);
    glm::vec3 d = glm::normalize(p.camera.target - p.camera.eye);
    const float yaw = glm::radians(90.0f * p.yaw);
    EXPECT_NEAR(d.x, std::cos(yaw), 1e-5);
    EXPECT_NEAR(d.y, 0.0f, 1e-6);
    EXPECT_NEAR(d.z, std::sin(yaw), 1e-5);
    EXPECT_NE(p.camera.label.find("cell " + std::to_string(p.column) + "," + std::to_string(p.row)), std::string::npos);
    json tag = poseJson(p, spec);
    EXPECT_EQ(tag["column"], p.column);
    EXPECT_EQ(tag["row"], p.row);
    EXPECT_EQ(tag["yaw"], p.yaw);
    EXPECT_EQ(tag["yaw_deg"].get<double>(), 90.0 * p.yaw);
  }
}

TEST(HeatmapPlacement, EyeHeightAndHeadroomMoveTheRule) {
  Scene scene = room();
  Bvh bvh = Bvh::build(scene);
  // Headroom 1.4: the floor under the shelf (1.5 m free) becomes walkable,
  // with eyes at 1.2 m under it.
  auto spec = parseHeatmapSpec({{"layout", "floor"}, {"cells", {20, 10}}, {"region", {{0, 0}, {20, 10}}},
                                {"yaws", 1}, {"eye_height", 1.2}, {"headroom", 1.4}});
  ASSERT_TRUE(spec) << spec.error();
  HeatmapPlacement placed = placeHeatmap(scene, bvh, *spec);
  EXPECT_NEAR(placed.layout["floor"][2][8].get<double>(), 0.0, 1e-6);
  for (const auto& p : placed.poses) EXPECT_NEAR(p.camera.eye.y, 1.2f, 1e-5);
}

TEST(HeatmapPlacement, AtriumFloorIsTheGroundStoreyInsideTheWalls) {
  Scene scene = makeAtrium();
  auto spec = parseHeatmapSpec({{"layout", "floor"}, {"cells", {12, 6}}, {"yaws", 2}});
  ASSERT_TRUE(spec) << spec.error();
  HeatmapPlacement placed = placeHeatmap(scene, *spec);
  const json& layout = placed.layout;
  EXPECT_NEAR(layout["ground"].get<double>(), 0.0, 1e-6);
  size_t court = 0;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 12; ++c) {
      const double x = layout["origin"][0].get<double>() + (c + 0.5) * layout["cell_size"][0].get<double>();
      const double z = layout["origin"][1].get<double>() + (r + 0.5) * layout["cell_size"][1].get<double>();
      const json& floor = layout["floor"][r][c];
      // Every floor is the ground storey's (y 0), never the upper gallery (4.9) or the roof (9.1).
      if (floor.is_number()) {
        EXPECT_NEAR(floor.get<double>(), 0.0, 1e-6);
        EXPECT_LT(std::abs(x), 12.0);
        EXPECT_LT(std::abs(z), 7.5);
      }
      // The open court between the arcades (|z| < 4.45 less clearance) and inside the end walls is all floor.
      if (std::abs(z) < 4.0 && std::abs(x) < 11.5) {
        EXPECT_TRUE(floor.is_number()) << "court cell " << c << "," << r << ": " << layout["empty"][r][c];
        ++court;
      }
    }
  }
  EXPECT_GT(court, 0u);
  for (const auto& p : placed.poses) EXPECT_NEAR(p.camera.eye.y, 1.7f, 1e-5);
}

TEST(HeatmapPlacement, SpherePosesAtTheDistanceLookingAtTheCentre) {
  Scene scene = makeAtrium();
  auto spec = parseHeatmapSpec({{"layout", "sphere"}, {"rings", 4}, {"segments", 8}, {"distance", 1.5}});
  ASSERT_TRUE(spec) << spec.error();
  HeatmapPlacement placed = placeHeatmap(scene, *spec);
  ASSERT_EQ(placed.poses.size(), 32u);
  const glm::vec3 center = scene.bounds.center();
  const float radius = 0.5f * scene.bounds.diagonal();
  EXPECT_EQ(placed.layout["layout"], "sphere");
  EXPECT_NEAR(placed.layout["distance"].get<double>(), 1.5 * radius, 1e-3);
  for (const auto& p : placed.poses) {
    EXPECT_NEAR(glm::length(p.camera.eye - center), 1.5f * radius, 1e-3f * radius);
    EXPECT_EQ(p.camera.target, center);
    // Row r is latitude 90 - (r + 0.5) * 45 degrees; column s longitude -180 + (s + 0.5) * 45.
    const float lat = glm::radians(90.0f - (p.row + 0.5f) * 45.0f);
    const float lon = glm::radians(-180.0f + (p.column + 0.5f) * 45.0f);
    glm::vec3 dir = glm::normalize(p.camera.eye - center);
    EXPECT_NEAR(dir.y, std::sin(lat), 1e-4);
    EXPECT_NEAR(dir.x, std::cos(lat) * std::cos(lon), 1e-4);
    EXPECT_NEAR(dir.z, std::cos(lat) * std::sin(lon), 1e-4);
  }
  EXPECT_NEAR(placed.layout["latitudes_deg"][0].get<double>(), 67.5, 1e-4);
  EXPECT_NEAR(placed.layout["longitudes_deg"][0].get<double>(), -157.5, 1e-4);
}

TEST(HeatmapTopDown, PlanShowsFloorSectionAndNothing) {
  Scene scene = room();
  Bvh bvh = Bvh::build(scene);
  HeatmapPlacement placed = placeHeatmap(scene, bvh, roomSpec());
  auto image = renderTopDown(scene, bvh, placed.layout);
  ASSERT_TRUE(image) << image.error();
  ASSERT_EQ(image->width, kTopDownMaxSide);
  ASSERT_EQ(image->height, kTopDownMaxSide / 2);  // 20 x 10 m
  auto at = [&](float x, float z) {
    uint32_t px = uint32_t(x / 20.0f * image->width), py = uint32_t(z / 10.0f * image->height);
    const uint8_t* p = &image->rgba[(size_t(py) * image->width + px) * 4];
    return std::array<int, 4>{p[0], p[1], p[2], p[3]};
  };
  EXPECT_EQ(at(18, 5)[3], 0);                                    // the hole: transparent
  EXPECT_EQ(at(5, 5), (std::array<int, 4>{52, 54, 62, 255}));    // the pillar, cut at 1.7 m: section fill
  auto floor = at(2, 8), shelf = at(9, 3);
  EXPECT_EQ(floor[3], 255);
  EXPECT_GT(shelf[0], floor[0]);  // the shelf is nearer the cut than the floor: lighter
  EXPECT_EQ(at(13, 5), floor);    // under the roof (above the cut): the floor
  // A sphere layout has no plan.
  auto sphere = parseHeatmapSpec({{"layout", "sphere"}});
  EXPECT_FALSE(renderTopDown(scene, bvh, placeHeatmap(scene, bvh, *sphere).layout));
}

TEST(HeatmapSpecTest, ErrorsNameTheField) {
  struct Case {
    json spec;
    std::string error;  // the start of the message
  };
  const std::vector<Case> cases = {
      {json::array(), "heatmap: must be an object"},
      {{{"cells", {4, 4}}}, "heatmap.layout: required"},
      {{{"layout", "grid"}}, "heatmap.layout: must be \"floor\" or \"sphere\""},
      {{{"layout", "floor"}, {"cells", {16, 0}}}, "heatmap.cells[1]: must be an integer between 1 and 256, got 0"},
      {{{"layout", "floor"}, {"cells", {16}}}, "heatmap.cells: must be [columns along x, rows along z]"},
      {{{"layout", "floor"}, {"cells", {"a", 2}}}, "heatmap.cells[0]: must be an integer"},
      {{{"layout", "floor"}, {"yaws", 0}}, "heatmap.yaws: must be an integer between 1 and 16"},
      {{{"layout", "floor"}, {"eye_height", -1}}, "heatmap.eye_height: must be a number above 0"},
      {{{"layout", "floor"}, {"eye_height", 2.5}}, "heatmap.headroom: must be above eye_height"},
      {{{"layout", "floor"}, {"pitch_deg", 90}}, "heatmap.pitch_deg: must be a number from -89 to 89"},
      {{{"layout", "floor"}, {"region", {{0, 0}, {0, 5}}}}, "heatmap.region[1][0]: must be above"},
      {{{"layout", "floor"}, {"region", {{0, 0}, {1}}}}, "heatmap.region[1]: must be [x, z]"},
      {{{"layout", "floor"}, {"rings", 3}}, "heatmap.rings: unknown field for the floor layout"},
      {{{"layout", "floor"}, {"cells", {256, 256}}}, "heatmap: cells x yaws is 262144 poses"},
      {{{"layout", "sphere"}, {"cells", {4, 4}}}, "heatmap.cells: unknown field for the sphere layout"},
      {{{"layout", "sphere"}, {"rings", 0}}, "heatmap.rings: must be an integer between 1 and 90"},
      {{{"layout", "sphere"}, {"distance", 0}}, "heatmap.distance: must be a number above 0"},
      {{{"layout", "sphere"}, {"fov_deg", 180}}, "heatmap.fov_deg: must be a number from 1 to 179"},
  };
  for (const auto& c : cases) {
    auto r = parseHeatmapSpec(c.spec);
    ASSERT_FALSE(r) << c.spec;
    EXPECT_EQ(r.error().rfind(c.error, 0), 0u) << c.spec << " -> " << r.error();
  }
  auto ok = parseHeatmapSpec({{"layout", "floor"}, {"cells", {3, 2}}, {"yaws", 8}});
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ(ok->maxPoses(), 48u);
}

// Sponza, a real scene: the floor found is the ground storey (nothing on the
// roofs or the upper galleries), the open courtyard's centre line is floor,
// and the eyes stand 1.7 m above it in open space.
TEST(HeatmapPlacement, SponzaCellsAreOnTheGroundInsideTheBuilding) {
  if (!std::filesystem::exists(TALLY_SPONZA_GLTF)) {
    TALLY_SKIP_UNLESS_STRICT("Sponza not found at " << TALLY_SPONZA_GLTF);
  }
  auto scene = makeSceneGeometry({{"gltf", TALLY_SPONZA_GLTF}});
  ASSERT_TRUE(scene) << scene.error();
  Bvh bvh = Bvh::build(*scene);
  auto spec = parseHeatmapSpec({{"layout", "floor"}, {"cells", {16, 8}}, {"yaws", 1}});
  ASSERT_TRUE(spec) << spec.error();
  HeatmapPlacement placed = placeHeatmap(*scene, bvh, *spec);
  const json& layout = placed.layout;
  const Bounds& b = scene->bounds;
  ASSERT_TRUE(layout["ground"].is_number()) << layout.dump();
  const double ground = layout["ground"].get<double>();
  // The ground storey lies in the lowest tenth of the building's height.
  EXPECT_LT(ground - b.min.y, 0.1 * (b.max.y - b.min.y)) << "ground " << ground;
  size_t floors = 0, middleRow = 0;
  for (int r = 0; r < 8; ++r) {
    for (int c = 0; c < 16; ++c) {
      const json& floor = layout["floor"][r][c];
      if (!floor.is_number()) continue;
      ++floors;
      EXPECT_LE(std::abs(floor.get<double>() - ground), 1.0) << "cell " << c << "," << r;
      if (r == 3 || r == 4) ++middleRow;
    }
  }
  // The courtyard runs along x through the middle: most of its middle rows are floor.
  EXPECT_GE(middleRow, 20u) << layout["empty"].dump();
  EXPECT_GE(floors, 40u);
  // The outermost ring of cells straddles the outer walls or lies outside: few floors there.
  for (const auto& p : placed.poses) {
    EXPECT_NEAR(p.camera.eye.y, layout["floor"][p.row][p.column].get<float>() + 1.7f, 2e-3);
    EXPECT_LT(p.camera.eye.y, b.min.y + 0.5f * (b.max.y - b.min.y));  // never on the roof
    // In open space: nothing within the clearance in any of 26 directions.
    for (int x = -1; x <= 1; ++x)
      for (int y = -1; y <= 1; ++y)
        for (int z = -1; z <= 1; ++z) {
          if (!x && !y && !z) continue;
          auto hit = bvh.closestHit({p.camera.eye, glm::normalize(glm::vec3(x, y, z))});
          if (hit) {
            EXPECT_GE(hit->t, 0.25f);
          }
        }
  }
  std::printf("sponza: ground %.3f, %zu of 128 cells with floor, empty %s\n", ground, floors,
              layout["empty_counts"].dump().c_str());
}

}  // namespace

// Automatic cameras of flat, thin and tiny scenes: each camera sees some of
// the geometry, a flat scene is seen from off its plane, and the near plane
// lies closer than anything the camera sees (no near-plane holes).
//
// "Sees" is checked without the ray caster the cameras are chosen with:
// points sampled on every triangle are projected with the camera's own view
// and projection (renderers' conventions: vertical field of view, 16:9),
// and one inside the view in front of the eye means the camera sees geometry
// (the test scenes are convex or flat, so nothing hides it).
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "strict.hpp"
#include <glm/gtc/matrix_transform.hpp>

#include "renderers/projection.hpp"
#include "scene_test_util.hpp"
#include "scenes/bvh.hpp"
#include "scenes/gltf.hpp"

namespace tally::scenes {
namespace {

// One mesh of the given triangles (positions only; normals along their faces).
Scene sceneOf(const std::vector<glm::vec3>& corners, const std::string& name) {
  Scene s;
  s.name = name;
  Mesh m;
  for (size_t i = 0; i + 2 < corners.size(); i += 3) {
    const glm::vec3 n = glm::normalize(glm::cross(corners[i + 1] - corners[i], corners[i + 2] - corners[i]));
    for (size_t k = 0; k < 3; ++k) {
      Vertex v{};
      v.position = corners[i + k];
      v.normal = n;
      v.tangent = glm::vec4(1, 0, 0, 1);
      m.indices.push_back(uint32_t(m.vertices.size()));
      m.vertices.push_back(v);
    }
  }
  s.meshes.push_back(std::move(m));
  s.materials.emplace_back();
  s.materials.back().doubleSided = true;
  updateBounds(s);
  return s;
}

std::vector<glm::vec3> quad(glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) { return {a, b, c, a, c, d}; }

// A box of the given size centred at the origin, as 12 triangles.
std::vector<glm::vec3> box(glm::vec3 size) {
  const glm::vec3 h = 0.5f * size;
  auto p = [&](int x, int y, int z) { return glm::vec3(x ? h.x : -h.x, y ? h.y : -h.y, z ? h.z : -h.z); };
  std::vector<glm::vec3> out;
  for (auto f : {quad(p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1)), quad(p(1, 0, 0), p(0, 0, 0), p(0, 1, 0), p(1, 1, 0)),
                 quad(p(1, 0, 1), p(1, 0, 0), p(1, 1, 0), p(1, 1, 1)), quad(p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0)),
                 quad(p(0, 1, 1), p(1, 1, 1), p(1, 1, 0), p(0, 1, 0)), quad(p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1))})
    out.insert(out.end(), f.begin(), f.end());
  return out;
}

// `corners` rotated so that +Z goes to `normal`.
std::vector<glm::vec3> facing(std::vector<glm::vec3> corners, glm::vec3 normal) {
  normal = glm::normalize(normal);
  const glm::vec3 z(0, 0, 1);
  const glm::vec3 axis = glm::cross(z, normal);
  if (glm::length(axis) < 1e-6f) {
    if (normal.z < 0) for (auto& c : corners) c = glm::vec3(c.x, -c.y, -c.z);
    return corners;
  }
  const glm::mat4 r = glm::rotate(glm::mat4(1.0f), std::acos(glm::dot(z, normal)), glm::normalize(axis));
  for (auto& c : corners) c = glm::vec3(r * glm::vec4(c, 1.0f));
  return corners;
}

// Whether a point sampled on some triangle projects inside the camera's view.
bool seesGeometry(const Scene& scene, const Camera& camera) {
  const glm::mat4 viewProj = renderers::perspective(glm::radians(camera.fovDeg), 16.0f / 9.0f, 1e-4f, 1e4f) *
                             viewMatrix(camera);
  for (const Mesh& m : scene.meshes)
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      const glm::vec3 a = m.vertices[m.indices[t]].position, b = m.vertices[m.indices[t + 1]].position,
                      c = m.vertices[m.indices[t + 2]].position;
      constexpr int kSteps = 24;
      for (int i = 0; i <= kSteps; ++i)
        for (int j = 0; i + j <= kSteps; ++j) {
          const glm::vec3 p = a + (b - a) * (float(i) / kSteps) + (c - a) * (float(j) / kSteps);
          const glm::vec4 clip = viewProj * glm::vec4(p, 1.0f);
          if (clip.w <= 0.0f) continue;
          if (std::abs(clip.x) <= clip.w && std::abs(clip.y) <= clip.w) return true;
        }
    }
  return false;
}

struct FlatCase {
  std::string name;
  std::vector<glm::vec3> corners;
  glm::vec3 normal;  // of the flat scene's plane
};

std::vector<FlatCase> flatCases() {
  std::vector<FlatCase> out;
  const std::vector<glm::vec3> triangle = {{-0.5f, -0.4f, 0}, {0.6f, -0.3f, 0}, {0.1f, 0.5f, 0}};
  const auto plane = quad({-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0});
  const auto panel = box({1.0f, 0.6f, 0.01f});  // 1 cm thick
  for (const glm::vec3& n : {glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1), glm::vec3(0.3f, 0.8f, -0.5f)}) {
    const std::string dir = "(" + std::to_string(int(n.x * 10)) + "," + std::to_string(int(n.y * 10)) + "," +
                            std::to_string(int(n.z * 10)) + ")";
    out.push_back({"triangle " + dir, facing(triangle, n), glm::normalize(n)});
    out.push_back({"plane " + dir, facing(plane, n), glm::normalize(n)});
    out.push_back({"panel " + dir, facing(panel, n), glm::normalize(n)});
  }
  return out;
}

TEST(AutoCamerasFlat, EveryCameraSeesTheFlatSceneAndSomeFromOffItsPlane) {
  for (const FlatCase& c : flatCases()) {
    const Scene scene = sceneOf(c.corners, c.name);
    const std::vector<Camera> cameras = autoCameras(scene);
    ASSERT_FALSE(cameras.empty()) << c.name;
    int offPlane = 0;
    for (const Camera& cam : cameras) {
      EXPECT_TRUE(seesGeometry(scene, cam)) << c.name << ": " << cam.label;
      EXPECT_LT(cam.skyFraction, 1.0f) << c.name << ": " << cam.label;
      // The angle between the view and the plane: 0 is edge-on (sees nothing of a plane).
      const glm::vec3 view = glm::normalize(cam.target - cam.eye);
      if (std::abs(glm::dot(view, c.normal)) > std::sin(glm::radians(10.0f))) ++offPlane;
    }
    EXPECT_GT(offPlane, 0) << c.name << ": no camera looks at the plane from off it";
  }
}

// The near plane is closer than the nearest surface each camera sees (rays
// on a 96 x 54 grid), and the far plane beyond the farthest bounds corner.
void expectNoNearPlaneHoles(const Scene& scene, const std::string& what) {
  const std::vector<Camera> cameras = autoCameras(scene);
  ASSERT_FALSE(cameras.empty()) << what;
  const Bvh bvh = Bvh::build(scene);
  for (const Camera& cam : cameras) {
    const renderers::DepthRange range = renderers::depthRangeFor(scene.bounds, cam);
    const glm::mat4 view = viewMatrix(cam);
    const glm::vec3 right(view[0][0], view[1][0], view[2][0]), up(view[0][1], view[1][1], view[2][1]);
    const glm::vec3 forward = glm::normalize(cam.target - cam.eye);
    const float tanHalf = std::tan(glm::radians(cam.fovDeg) * 0.5f);
    float nearest = std::numeric_limits<float>::max();
    for (int j = 0; j < 54; ++j)
      for (int i = 0; i < 96; ++i) {
        const float x = (2.0f * (i + 0.5f) / 96 - 1.0f) * tanHalf * 16.0f / 9.0f;
        const float y = (1.0f - 2.0f * (j + 0.5f) / 54) * tanHalf;
        const glm::vec3 d = glm::normalize(forward + right * x + up * y);
        if (auto hit = bvh.closestHit({cam.eye, d})) nearest = std::min(nearest, hit->t * glm::dot(d, forward));
      }
    EXPECT_LT(range.zNear, nearest) << what << ": " << cam.label << " sees a surface nearer than its near plane";
    for (int k = 0; k < 8; ++k) {
      const glm::vec3 corner((k & 1) ? scene.bounds.max.x : scene.bounds.min.x, (k & 2) ? scene.bounds.max.y : scene.bounds.min.y,
                             (k & 4) ? scene.bounds.max.z : scene.bounds.min.z);
      EXPECT_GT(range.zFar, glm::length(corner - cam.eye)) << what;
    }
  }
}

TEST(AutoCamerasFlat, TinyModelsHaveNoNearPlaneHoles) {
  expectNoNearPlaneHoles(sceneOf(box({0.1f, 0.06f, 0.08f}), "10 cm box"), "10 cm box");
  expectNoNearPlaneHoles(sceneOf(facing(box({0.1f, 0.1f, 0.002f}), {0.2f, 1.0f, 0.1f}), "10 cm panel"), "10 cm panel");
}

TEST(AutoCamerasFlat, ToyCarHasNoNearPlaneHolesAndEveryCameraSeesIt) {
  const std::string path =
      (std::filesystem::path(TALLY_SPONZA_GLTF).parent_path().parent_path() / "khronos/ToyCar/glTF/ToyCar.gltf").string();
  if (!std::filesystem::exists(path)) TALLY_SKIP_UNLESS_STRICT("no " << path);
  Result<Scene> scene = loadGltf(path);
  ASSERT_TRUE(scene.ok()) << scene.error();
  ASSERT_LT(scene->bounds.diagonal(), 0.2f) << "ToyCar is about 0.1 m across";
  expectNoNearPlaneHoles(*scene, "ToyCar");
  for (const Camera& cam : autoCameras(*scene)) EXPECT_LT(cam.skyFraction, 1.0f) << cam.label;
}

// A single-sided triangle (a material without doubleSided) in the XY plane,
// written as a glTF file: its back face is culled when drawn, so a camera
// behind it sees only sky. Every automatic camera must look at its front
// (the +Z side: counter-clockwise there), see some of it as drawn, and have
// a sky fraction measured as drawn.
TEST(AutoCamerasFlat, ASingleSidedTriangleIsSeenFromItsFront) {
  test::TempDir dir;
  test::GltfWriter w;
  std::vector<float> pos = {-0.5f, -0.4f, 0.0f, 0.6f, -0.3f, 0.0f, 0.1f, 0.5f, 0.0f};
  std::vector<float> nrm = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  nlohmann::json prim = {
      {"attributes",
       {{"POSITION", w.accessor(pos, 5126, "VEC3", 3)}, {"NORMAL", w.accessor(nrm, 5126, "VEC3", 3)}}},
      {"material", 0}};
  w.doc["materials"] = {
      {{"name", "one side"}, {"pbrMetallicRoughness", {{"baseColorFactor", {1, 1, 1, 1}}}}}};
  w.meshNode({prim});
  auto loaded = loadGltf(w.write(dir, "triangle.gltf"));
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  const Scene& scene = *loaded;
  ASSERT_EQ(scene.triangleCount(), 1u);
  ASSERT_FALSE(scene.materials[scene.meshes[0].material].doubleSided);

  // The ray caster as drawn: the front is a hit, the back is not.
  const Bvh bvh = Bvh::build(scene);
  Ray front{glm::vec3(0.05f, 0.0f, 2.0f), glm::vec3(0, 0, -1)};
  Ray back{glm::vec3(0.05f, 0.0f, -2.0f), glm::vec3(0, 0, 1)};
  front.cullBackFaces = back.cullBackFaces = true;
  EXPECT_TRUE(bvh.anyHit(front));
  EXPECT_FALSE(bvh.anyHit(back));
  back.cullBackFaces = false;
  EXPECT_TRUE(bvh.anyHit(back)) << "without culling both sides are hits";

  const std::vector<Camera> cameras = autoCameras(scene);
  ASSERT_FALSE(cameras.empty());
  const glm::vec3 normal(0, 0, 1), centre(0.067f, -0.067f, 0.0f);
  for (const Camera& cam : cameras) {
    EXPECT_GT(glm::dot(cam.eye - centre, normal), 0.0f) << "behind the triangle: " << cam.label;
    EXPECT_TRUE(seesGeometry(scene, cam)) << cam.label;
    EXPECT_LT(cam.skyFraction, 1.0f) << cam.label;
    EXPECT_FLOAT_EQ(cam.skyFraction, skyFraction(bvh, cam)) << cam.label;
  }
  // The same triangle double-sided is seen from both sides.
  Scene both = scene;
  both.materials[both.meshes[0].material].doubleSided = true;
  int behind = 0;
  for (const Camera& cam : autoCameras(both)) behind += glm::dot(cam.eye - centre, normal) < 0.0f ? 1 : 0;
  EXPECT_GT(behind, 0);
}

}  // namespace
}  // namespace tally::scenes

// glTF loading: small files written by the test, and the Crytek Sponza when
// ../shared/scenes/sponza is present.
#include <cstdlib>
#include <chrono>
#include <filesystem>

#include <gtest/gtest.h>

#include "strict.hpp"

#include "scene_test_util.hpp"
#include "scenes/cameras.hpp"
#include "scenes/gltf.hpp"

namespace tally::scenes {
namespace {

using nlohmann::json;
using test::GltfWriter;
using test::TempDir;

TEST(Gltf, NodeTransformsAreApplied) {
  TempDir dir;
  GltfWriter w;
  json& node = w.meshNode({w.quadPrimitive()});
  node["translation"] = {10, 0, 0};
  node["scale"] = {2, 2, 2};
  // A parent rotating 90 degrees about +Y (quaternion x, y, z, w).
  w.doc["nodes"].push_back({{"children", {0}}, {"rotation", {0, std::sqrt(0.5), 0, std::sqrt(0.5)}}});
  w.doc["scenes"][0]["nodes"] = {1};
  Result<Scene> r = loadGltf(w.write(dir, "t.gltf"));
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_EQ(r->meshes.size(), 1u);
  EXPECT_EQ(r->triangleCount(), 2u);
  // Scale, then translate, then the parent's rotation (+X to -Z):
  // corner (1, 1, 0) -> (2, 2, 0) -> (12, 2, 0) -> (0, 2, -12).
  const Bounds& b = r->bounds;
  EXPECT_NEAR(b.min.z, -12.0f, 1e-4f);
  EXPECT_NEAR(b.max.z, -10.0f, 1e-4f);
  EXPECT_NEAR(b.max.y, 2.0f, 1e-4f);
  EXPECT_NEAR(b.max.x, 0.0f, 1e-4f);
  // The normal (+Z) rotates to +X; the derived tangent follows +u (+X -> -Z).
  const Vertex& v = r->meshes[0].vertices[0];
  EXPECT_NEAR(v.normal.x, 1.0f, 1e-5f);
  EXPECT_NEAR(v.tangent.z, -1.0f, 1e-5f);
  test::expectOrthonormalTangents(*r);
  EXPECT_EQ(r->name, "t");
  EXPECT_EQ(r->materials.size(), 1u) << "a default material for a primitive without one";
}

TEST(Gltf, MirroringKeepsFrontFacesCounterClockwise) {
  TempDir dir;
  GltfWriter w;
  w.meshNode({w.quadPrimitive()})["scale"] = {-1, 1, 1};
  Result<Scene> r = loadGltf(w.write(dir, "m.gltf"));
  ASSERT_TRUE(r.ok()) << r.error();
  const Mesh& m = r->meshes[0];
  for (size_t i = 0; i < m.indices.size(); i += 3) {
    glm::vec3 a = m.vertices[m.indices[i]].position, b = m.vertices[m.indices[i + 1]].position,
              c = m.vertices[m.indices[i + 2]].position;
    EXPECT_GT(glm::dot(glm::cross(b - a, c - a), m.vertices[m.indices[i]].normal), 0.0f);
  }
  test::expectOrthonormalTangents(*r);
}

TEST(Gltf, FileTangentsAreKept) {
  TempDir dir;
  GltfWriter w;
  json prim = w.quadPrimitive(5125);
  prim["attributes"]["TANGENT"] =
      w.accessor(std::vector<float>{0, 1, 0, -1, 0, 1, 0, -1, 0, 1, 0, -1, 0, 1, 0, -1}, 5126, "VEC4", 4);
  w.meshNode({prim});
  Result<Scene> r = loadGltf(w.write(dir, "t.gltf"));
  ASSERT_TRUE(r.ok()) << r.error();
  for (const Vertex& v : r->meshes[0].vertices) EXPECT_EQ(v.tangent, glm::vec4(0, 1, 0, -1));
}

TEST(Gltf, StripsBecomeListsAndLinesAreRefused) {
  TempDir dir;
  GltfWriter w;
  json strip = w.quadPrimitive();
  strip["mode"] = 5;
  strip["indices"] = w.accessor(std::vector<uint8_t>{0, 1, 3, 2}, 5121, "SCALAR", 4);
  w.meshNode({strip});
  Result<Scene> r = loadGltf(w.write(dir, "s.gltf"));
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->triangleCount(), 2u);
  EXPECT_TRUE(r->notes.empty());
  // Lines are not drawn: the file is refused, naming the primitive and its mode.
  GltfWriter withLines;
  json lines = withLines.quadPrimitive();
  lines["mode"] = 1;
  withLines.meshNode({withLines.quadPrimitive(), lines});
  Result<Scene> refused = loadGltf(withLines.write(dir, "lines.gltf"));
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().find("primitive 1: mode 1 (LINES)"), std::string::npos) << refused.error();
  EXPECT_NE(refused.error().find("lines.gltf"), std::string::npos) << refused.error();
}

TEST(Gltf, MaterialsMapToTheFiveSlots) {
  TempDir dir;
  GltfWriter w;
  json prim = w.quadPrimitive();
  prim["material"] = 0;
  w.meshNode({prim});
  w.doc["images"] = {{{"uri", test::kTestPngDataUri}}, {{"uri", test::kTestPngDataUri}}};
  w.doc["textures"] = {{{"source", 0}}, {{"source", 1}}};
  w.doc["extensionsUsed"] = {"KHR_materials_specular"};
  w.doc["materials"] = {
      {{"name", "mat"},
       {"pbrMetallicRoughness",
        {{"baseColorTexture", {{"index", 0}}}, {"metallicRoughnessTexture", {{"index", 1}}}}},
       {"normalTexture", {{"index", 0}}},
       {"extensions", {{"KHR_materials_specular", {{"specularColorTexture", {{"index", 1}}}}}}}}};
  Result<Scene> r = loadGltf(w.write(dir, "mat.gltf"), {.maxTextureSize = 2});
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_EQ(r->materials.size(), 1u);
  const Material& m = r->materials[0];
  EXPECT_EQ(m.name, "mat");
  EXPECT_EQ(m.map(MapSlot::Ambient), -1) << "no occlusion texture: the dummy";
  // One texture per (image, colour space): image 0 sRGB (diffuse) and linear
  // (normal); image 1 linear (roughness) and sRGB (specular colour).
  ASSERT_EQ(r->textures.size(), 4u);
  const std::pair<MapSlot, bool> expect[] = {{MapSlot::Diffuse, true},
                                             {MapSlot::Specular, true},
                                             {MapSlot::Roughness, false},
                                             {MapSlot::Normal, false}};
  for (auto [slot, srgb] : expect) {
    ASSERT_GE(m.map(slot), 0) << toString(slot);
    const Texture& t = r->textures[size_t(m.map(slot))];
    EXPECT_EQ(t.srgb, srgb) << toString(slot);
    // Decoded 4x4, box-filtered to 2x2: red, green / blue, grey (0+100+200+100)/4.
    ASSERT_EQ(t.width, 2u);
    ASSERT_EQ(t.height, 2u);
    const uint8_t want[16] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 100, 100, 100, 255};
    EXPECT_EQ(std::vector<uint8_t>(t.rgba8.begin(), t.rgba8.end()), std::vector<uint8_t>(want, want + 16));
  }
  EXPECT_NE(m.map(MapSlot::Diffuse), m.map(MapSlot::Normal));
}

struct BadFile {
  const char* name;
  std::function<void(GltfWriter&)> edit;
  const char* mentions;
};

TEST(Gltf, BrokenFilesGiveClearErrors) {
  const BadFile cases[] = {
      {"float-indices", [](GltfWriter& w) { w.meshNode({w.quadPrimitive(5126)}); },
       "unsupported index component type 5126"},
      {"index-range",
       [](GltfWriter& w) {
         json p = w.quadPrimitive();
         p["indices"] = w.accessor(std::vector<uint16_t>{0, 1, 9}, 5123, "SCALAR", 3);
         w.meshNode({p});
       },
       "index 9 out of range"},
      {"past-end",
       [](GltfWriter& w) {
         json p = w.quadPrimitive();
         w.doc["accessors"][p["attributes"]["POSITION"].get<int>()]["count"] = 400;
         w.meshNode({p});
       },
       "reads past the end of buffer"},
      {"no-position",
       [](GltfWriter& w) {
         json p = w.quadPrimitive();
         p["attributes"].erase("POSITION");
         w.meshNode({p});
       },
       "no POSITION"},
      {"missing-image",
       [](GltfWriter& w) {
         json p = w.quadPrimitive();
         p["material"] = 0;
         w.meshNode({p});
         w.doc["images"] = {{{"uri", "missing.png"}}};
         w.doc["textures"] = {{{"source", 0}}};
         w.doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
       },
       "missing.png"},
      {"draco",
       [](GltfWriter& w) {
         w.meshNode({w.quadPrimitive()});
         w.doc["extensionsRequired"] = {"KHR_draco_mesh_compression"};
         w.doc["extensionsUsed"] = {"KHR_draco_mesh_compression"};
       },
       "KHR_draco_mesh_compression"},
  };
  for (const BadFile& c : cases) {
    TempDir dir;
    GltfWriter w;
    c.edit(w);
    std::string path = w.write(dir, std::string(c.name) + ".gltf");
    Result<Scene> r = loadGltf(path);
    ASSERT_FALSE(r.ok()) << c.name;
    EXPECT_EQ(r.error().rfind("\"" + path + "\": ", 0), 0u) << r.error();
    EXPECT_NE(r.error().find(c.mentions), std::string::npos) << c.name << " -> " << r.error();
  }
}

TEST(Gltf, MissingBufferFile) {
  TempDir dir;
  GltfWriter w;
  w.meshNode({w.quadPrimitive()});
  w.write(dir, "b.gltf");
  w.doc["buffers"][0]["uri"] = "missing.bin";
  std::string path = dir.write("b.gltf", w.doc.dump());
  Result<Scene> r = loadGltf(path);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("missing.bin"), std::string::npos) << r.error();
}

TEST(Gltf, MissingFile) {
  Result<Scene> r = loadGltf("/nonexistent/scene.gltf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error(), "\"/nonexistent/scene.gltf\": file not found");
}

// --- Crytek Sponza -----------------------------------------------------------

Result<Scene> loadSponza(double* seconds) {
  auto t0 = std::chrono::steady_clock::now();
  // 64x64 textures: decoding still happens at full size, but the test keeps
  // little memory; the geometry is what these tests check.
  Result<Scene> r = loadGltf(TALLY_SPONZA_GLTF, {.maxTextureSize = 64});
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

TEST(Sponza, LoadsWithDerivedTangents) {
  if (!std::filesystem::exists(TALLY_SPONZA_GLTF)) {
    // CI and scripts/test.sh always have ../shared beside the clone: there a missing file is a failure.
    TALLY_SKIP_UNLESS_STRICT("Sponza not found at " << TALLY_SPONZA_GLTF);
  }
  double seconds = 0.0;
  Result<Scene> r = loadSponza(&seconds);
  ASSERT_TRUE(r.ok()) << r.error();
  const Scene& s = *r;
  std::printf(
      "Sponza: loaded in %.2f s: %zu triangles, %zu meshes, %zu materials, %zu textures; bounds (%.2f %.2f "
      "%.2f)..(%.2f %.2f %.2f)\n",
      seconds, s.triangleCount(), s.meshes.size(), s.materials.size(), s.textures.size(), s.bounds.min.x,
      s.bounds.min.y, s.bounds.min.z, s.bounds.max.x, s.bounds.max.y, s.bounds.max.z);
  EXPECT_EQ(s.triangleCount(), 262267u);
  EXPECT_EQ(s.materials.size(), 25u);
  EXPECT_EQ(s.textures.size(), 69u);
  for (const Texture& t : s.textures) {
    EXPECT_LE(std::max(t.width, t.height), 64u) << t.name;
    EXPECT_EQ(t.rgba8.size(), size_t(t.width) * t.height * 4) << t.name;
  }
  for (const std::string& n : s.notes) std::printf("  note: %s\n", n.c_str());
  test::expectOrthonormalTangents(s, 1e-3f);
}

TEST(Sponza, AutoCamerasCoverTheSkyCategories) {
  if (!std::filesystem::exists(TALLY_SPONZA_GLTF)) {
    // CI and scripts/test.sh always have ../shared beside the clone: there a missing file is a failure.
    TALLY_SKIP_UNLESS_STRICT("Sponza not found at " << TALLY_SPONZA_GLTF);
  }
  double seconds = 0.0;
  Result<Scene> r = loadSponza(&seconds);
  ASSERT_TRUE(r.ok()) << r.error();
  auto t0 = std::chrono::steady_clock::now();
  std::vector<Camera> cams = autoCameras(*r);
  double camSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("Sponza auto cameras (BVH + search + 10 x 96x54 rays): %.2f s\n", camSeconds);
  test::printCameras(cams);
  test::expectSkyCategories(cams);
}

}  // namespace
}  // namespace tally::scenes

// makeScene: specs in, scenes or errors naming the field out (table-driven).
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "scene_test_util.hpp"
#include "scenes/spec.hpp"

namespace tally::scenes {
namespace {

using nlohmann::json;

struct BadSpec {
  json spec;
  std::string prefix;  // the error must start with this (the field)
  std::string mentions;
};

TEST(Spec, BadSpecsNameTheField) {
  const BadSpec cases[] = {
      {"nowhere", "unknown scene \"nowhere\"", "atrium"},
      {5, "must be a scene name or an object", "5"},
      {json::object(), "name: missing", "gltf"},
      {{{"name", "nowhere"}}, "name: unknown scene \"nowhere\"", "planes"},
      {{{"name", 3}}, "name: unknown scene 3", ""},
      {{{"name", "planes"}, {"layers", 0}}, "layers: must be an integer between 1 and 1024, got 0", ""},
      {{{"name", "planes"}, {"layers", "x"}}, "layers: must be an integer between 1 and 1024, got \"x\"", ""},
      {{{"name", "planes"}, {"layers", 2.5}}, "layers: must be an integer", "2.5"},
      {{{"name", "planes"}, {"layers", 1025}}, "layers: must be an integer", "1025"},
      {{{"name", "planes"}, {"layers", -3}}, "layers: must be an integer", "-3"},
      {{{"name", "planes"}, {"order", "sideways"}},
       "order: must be \"back-to-front\" or \"front-to-back\"",
       "sideways"},
      {{{"name", "planes"}, {"coverage", 1.5}}, "coverage: must be a number in (0, 1]", "1.5"},
      {{{"name", "planes"}, {"coverage", 0}}, "coverage: must be a number in (0, 1]", ""},
      {{{"name", "planes"}, {"coverage", "full"}}, "coverage: must be a number", "full"},
      {{{"name", "sky"}, {"coverage", -0.1}}, "coverage: must be a number in [0, 1]", "-0.1"},
      {{{"name", "planes"}, {"layer", 8}}, "layer: unknown key", "layers"},
      {{{"name", "atrium"}, {"coverage", 1}}, "coverage: unknown key for scene \"atrium\"", ""},
      {{{"name", "sky"}, {"layers", 2}}, "layers: unknown key for scene \"sky\"", ""},
      {{{"gltf", "/nonexistent/dir/scene.gltf"}}, "gltf: ", "file not found"},
      {{{"gltf", 5}}, "gltf: must be a non-empty path string", ""},
      {{{"gltf", ""}}, "gltf: must be a non-empty path string", ""},
      {{{"gltf", "x.gltf"}, {"name", "atrium"}}, "name: cannot be combined with gltf", ""},
      {{{"gltf", "x.gltf"}, {"max_texture_size", 0}},
       "max_texture_size: must be an integer between 1 and 16384",
       ""},
      {{{"gltf", "x.gltf"}, {"max_texure_size", 64}}, "max_texure_size: unknown key", ""},
  };
  for (const BadSpec& c : cases) {
    Result<Scene> r = makeScene(c.spec);
    ASSERT_FALSE(r.ok()) << c.spec.dump();
    EXPECT_EQ(r.error().rfind(c.prefix, 0), 0u) << c.spec.dump() << " -> " << r.error();
    EXPECT_NE(r.error().find(c.mentions), std::string::npos) << c.spec.dump() << " -> " << r.error();
    // The cheap check refuses the same specs with the same error, except a
    // file it does not open.
    Result<json> checked = checkSceneSpec(c.spec);
    if (c.mentions == "file not found") {
      EXPECT_TRUE(checked.ok()) << c.spec.dump() << " -> " << checked.error();
    } else {
      ASSERT_FALSE(checked.ok()) << c.spec.dump();
      EXPECT_EQ(checked.error(), r.error());
    }
  }
}

TEST(Spec, CheckedSpecsAreCanonical) {
  const std::vector<std::pair<json, json>> same = {
      {"atrium", {{"name", "atrium"}}},
      {"planes", {{"name", "planes"}, {"layers", 8}, {"order", "back-to-front"}, {"coverage", 1.0}}},
      {{{"name", "planes"}, {"coverage", 1}}, {{"name", "planes"}, {"layers", 8}}},
      {"sky", {{"name", "sky"}, {"coverage", 0.5}}},
  };
  for (const auto& [a, b] : same) {
    auto ca = checkSceneSpec(a), cb = checkSceneSpec(b);
    ASSERT_TRUE(ca.ok() && cb.ok()) << a.dump() << " " << b.dump();
    EXPECT_EQ(*ca, *cb) << a.dump() << " vs " << b.dump();
  }
  auto planes2 = checkSceneSpec({{"name", "planes"}, {"layers", 2}});
  auto planes8 = checkSceneSpec("planes");
  ASSERT_TRUE(planes2.ok() && planes8.ok());
  EXPECT_NE(*planes2, *planes8);
}

TEST(Spec, CorruptGltfIsAnError) {
  test::TempDir dir;
  const std::string files[][2] = {
      {"corrupt.gltf", "{ \"asset\": {\"version\": \"2.0\"}, \"meshes\": [ "},  // truncated JSON
      {"image.gltf", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16)},         // not glTF at all
      {"broken.glb", std::string("glTF\x02\0\0\0\x10\0\0\0", 12)},              // binary header, no chunks
      {"empty.gltf", ""},
  };
  for (const auto& [name, bytes] : files) {
    std::string path = dir.write(name, bytes);
    Result<Scene> r = makeScene({{"gltf", path}});
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_EQ(r.error().rfind("gltf: ", 0), 0u) << r.error();
    EXPECT_NE(r.error().find(path), std::string::npos) << r.error();
    EXPECT_NE(r.error().find("not a valid glTF"), std::string::npos) << r.error();
  }
}

TEST(Spec, NamesAndObjectsBuildTheScenes) {
  Result<Scene> atrium = makeScene("atrium");
  ASSERT_TRUE(atrium.ok()) << atrium.error();
  EXPECT_EQ(atrium->name, "atrium");

  Result<Scene> planes =
      makeScene({{"name", "planes"}, {"layers", 3}, {"order", "front-to-back"}, {"coverage", 0.5}});
  ASSERT_TRUE(planes.ok()) << planes.error();
  EXPECT_EQ(planes->triangleCount(), 6u);
  EXPECT_EQ(planes->params,
            (json{{"name", "planes"}, {"layers", 3}, {"order", "front-to-back"}, {"coverage", 0.5}}));

  Result<Scene> defaults = makeScene("planes");
  ASSERT_TRUE(defaults.ok());
  EXPECT_EQ(defaults->params["layers"], 8);
  EXPECT_EQ(defaults->params["order"], "back-to-front");

  // Parameters are echoed as given (0.3 stays 0.3, not its float neighbour).
  Result<Scene> third = makeScene({{"name", "planes"}, {"coverage", 0.3}});
  ASSERT_TRUE(third.ok()) << third.error();
  EXPECT_EQ(third->params["coverage"].dump(), "0.3");

  Result<Scene> sky = makeScene({{"name", "sky"}, {"coverage", 0}});
  ASSERT_TRUE(sky.ok()) << sky.error();
  EXPECT_EQ(sky->params["coverage"], 0.0);
}

}  // namespace
}  // namespace tally::scenes

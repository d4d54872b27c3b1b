// Helpers shared by the scene tests: invariant checks, temporary files and a
// tiny glTF writer (buffers embedded as base64 data URIs).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "scenes/cameras.hpp"
#include "scenes/scene.hpp"

namespace tally::scenes::test {

// A fresh directory under the system temp dir, removed with the object.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            ("tally_scene_tests_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
             std::to_string(::getpid()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string write(const std::string& name, const std::string& bytes) const {
    std::string p = (path_ / name).string();
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
  }
  std::string path(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

inline std::string base64(const std::vector<uint8_t>& data) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < data.size(); i += 3) {
    uint32_t v = uint32_t(data[i]) << 16;
    if (i + 1 < data.size()) v |= uint32_t(data[i + 1]) << 8;
    if (i + 2 < data.size()) v |= data[i + 2];
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < data.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < data.size() ? k[v & 63] : '=';
  }
  return out;
}

// Builds a glTF document with one embedded buffer.
struct GltfWriter {
  nlohmann::json doc = {{"asset", {{"version", "2.0"}}},
                        {"bufferViews", nlohmann::json::array()},
                        {"accessors", nlohmann::json::array()}};
  std::vector<uint8_t> bin;

  template <class T>
  int accessor(const std::vector<T>& data, int componentType, const char* type, size_t count) {
    while (bin.size() % 4) bin.push_back(0);
    size_t offset = bin.size();
    const auto* p = reinterpret_cast<const uint8_t*>(data.data());
    bin.insert(bin.end(), p, p + data.size() * sizeof(T));
    doc["bufferViews"].push_back(
        {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", data.size() * sizeof(T)}});
    doc["accessors"].push_back({{"bufferView", doc["bufferViews"].size() - 1},
                                {"componentType", componentType},
                                {"type", type},
                                {"count", count}});
    return int(doc["accessors"].size() - 1);
  }

  // The unit quad in the XY plane facing +Z, UVs with v down the image.
  nlohmann::json quadPrimitive(int indexComponentType = 5123) {
    std::vector<float> pos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    std::vector<float> nrm = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    std::vector<float> uv = {0, 1, 1, 1, 1, 0, 0, 0};
    nlohmann::json prim = {{"attributes",
                            {{"POSITION", accessor(pos, 5126, "VEC3", 4)},
                             {"NORMAL", accessor(nrm, 5126, "VEC3", 4)},
                             {"TEXCOORD_0", accessor(uv, 5126, "VEC2", 4)}}}};
    if (indexComponentType == 5123)
      prim["indices"] = accessor(std::vector<uint16_t>{0, 1, 2, 0, 2, 3}, 5123, "SCALAR", 6);
    if (indexComponentType == 5125)
      prim["indices"] = accessor(std::vector<uint32_t>{0, 1, 2, 0, 2, 3}, 5125, "SCALAR", 6);
    if (indexComponentType == 5126)
      prim["indices"] = accessor(std::vector<float>{0, 1, 2, 0, 2, 3}, 5126, "SCALAR", 6);
    return prim;
  }

  // One mesh with the given primitives under one node; returns the node for edits.
  // (A vector, not a json: `{prim}` would copy prim rather than make an array.)
  nlohmann::json& meshNode(const std::vector<nlohmann::json>& primitives) {
    doc["meshes"] = {{{"name", "m"}, {"primitives", nlohmann::json(primitives)}}};
    doc["nodes"] = {{{"mesh", 0}}};
    doc["scenes"] = {{{"nodes", {0}}}};
    doc["scene"] = 0;
    return doc["nodes"][0];
  }

  // Broken-file tests: a byteLength other than the data's, text instead of
  // the document, and a flag the test acts on after writing.
  std::optional<uint64_t> declaredBufferBytes;
  std::string rawText;
  bool hugePng = false;

  std::string write(const TempDir& dir, const std::string& name) {
    doc["buffers"] = {{{"byteLength", declaredBufferBytes.value_or(bin.size())},
                       {"uri", "data:application/octet-stream;base64," + base64(bin)}}};
    return dir.write(name, rawText.empty() ? doc.dump() : rawText);
  }
};

// 4x4 RGBA PNG: 2x2 blocks red, green, blue and a grey block of 0/100/200/100.
inline const char* kTestPngDataUri =
    "data:image/"
    "png;base64,iVBORw0KGgoAAAANSUhEUgAAAAQAAAAECAYAAACp8Z5+"
    "AAAAIElEQVR4nGP4z8DwH4SRIJoAlA9mpKSkIAROnDgBFgAAIeIglbk5UroAAAAASUVORK5CYII=";

// Every vertex: unit normal, unit tangent orthogonal to it, w = +-1.
inline void expectOrthonormalTangents(const Scene& scene, float tolerance = 1e-3f) {
  size_t bad = 0;
  for (const Mesh& m : scene.meshes)
    for (const Vertex& v : m.vertices) {
      glm::vec3 t(v.tangent);
      bool ok = std::abs(glm::length(v.normal) - 1.0f) < tolerance &&
                std::abs(glm::length(t) - 1.0f) < tolerance && std::abs(glm::dot(t, v.normal)) < tolerance &&
                std::abs(std::abs(v.tangent.w) - 1.0f) == 0.0f;
      if (!ok && bad++ < 5)
        ADD_FAILURE() << m.name << ": n=(" << v.normal.x << "," << v.normal.y << "," << v.normal.z << ") t=("
                      << t.x << "," << t.y << "," << t.z << "," << v.tangent.w << ")";
    }
  EXPECT_EQ(bad, 0u);
}

// The founding study's protocol: 10 cameras, one mostly sky, one about half
// sky, one all geometry.
inline void expectSkyCategories(const std::vector<Camera>& cams) {
  ASSERT_EQ(cams.size(), size_t(kAutoCameraCount));
  bool mostly = false, half = false, none = false;
  for (const Camera& c : cams) {
    EXPECT_GE(c.skyFraction, 0.0f) << c.label;
    EXPECT_LE(c.skyFraction, 1.0f) << c.label;
    mostly = mostly || c.skyFraction > kMostlySky;
    half = half || (c.skyFraction >= kHalfSkyLo && c.skyFraction <= kHalfSkyHi);
    none = none || c.skyFraction < kAllGeometry;
  }
  EXPECT_TRUE(mostly) << "no mostly-sky camera";
  EXPECT_TRUE(half) << "no half-sky camera";
  EXPECT_TRUE(none) << "no all-geometry camera";
}

inline void printCameras(const std::vector<Camera>& cams) {
  for (const Camera& c : cams) std::printf("  sky %.3f  %s\n", c.skyFraction, c.label.c_str());
}

}  // namespace tally::scenes::test

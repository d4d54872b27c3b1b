// Small glTF files written by the tests: quads with materials, textures
// (PNG files beside the .gltf), optional COLOR_0 and TEXCOORD_1, and node
// transforms. Everything a test asserts about the file is in the test's own
// source: this only serialises it.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

namespace tally::testing {

struct GltfQuad {
  // Corners counter-clockwise as seen from the front (glTF: front faces wind CCW).
  std::array<glm::vec3, 4> corners;
  std::array<glm::vec2, 4> uv{glm::vec2(0, 0), glm::vec2(1, 0), glm::vec2(1, 1), glm::vec2(0, 1)};
  std::optional<std::array<glm::vec2, 4>> uv1;    // TEXCOORD_1
  std::optional<std::array<glm::vec4, 4>> color;  // COLOR_0 (float VEC4)
  int material = -1;
  nlohmann::json node = nlohmann::json::object();  // extra node fields: "scale", "translation", "matrix"...
};

class GltfWriter {
 public:
  // A width x height RGBA8 image (rows top to bottom) as a PNG file; the
  // texture uses `sampler` (a glTF sampler object; {} the default). Returns
  // the texture index.
  int addTexture(int width, int height, const std::vector<uint8_t>& rgba, const nlohmann::json& sampler = {});
  // A glTF material object; returns its index.
  int addMaterial(const nlohmann::json& material);
  void addQuad(const GltfQuad& quad);
  // extensionsUsed / extensionsRequired of the file.
  void useExtension(const std::string& name, bool required = false);
  // Writes <dir>/<name>.gltf, its .bin and PNGs; returns the .gltf path.
  std::string write(const std::string& dir, const std::string& name) const;

 private:
  struct Image {
    int width, height;
    std::vector<uint8_t> rgba;
  };
  std::vector<Image> images_;
  nlohmann::json textures_ = nlohmann::json::array();
  nlohmann::json samplers_ = nlohmann::json::array();
  nlohmann::json materials_ = nlohmann::json::array();
  std::vector<GltfQuad> quads_;
  std::vector<std::string> used_, required_;
};

// A fresh empty folder under the system temp directory.
std::string tempFolder(const std::string& prefix);

// A quad facing +Z (towards a camera on +Z looking down -Z) spanning
// [x0, x1] x [y0, y1] at depth z, uv (0,0) at (x0, y0) .. (1,1) at (x1, y1).
GltfQuad quadFacingCamera(float x0, float y0, float x1, float y1, float z, int material);

}  // namespace tally::testing

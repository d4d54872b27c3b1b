#include "gltf_writer.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <stb_image_write.h>

namespace tally::testing {
namespace {

// Appends `bytes` at a 4-byte aligned offset; returns the offset.
size_t append(std::vector<uint8_t>& bin, const void* bytes, size_t size) {
  while (bin.size() % 4 != 0) bin.push_back(0);
  const size_t offset = bin.size();
  bin.resize(offset + size);
  std::memcpy(bin.data() + offset, bytes, size);
  return offset;
}

}  // namespace

int GltfWriter::addTexture(int width, int height, const std::vector<uint8_t>& rgba, const nlohmann::json& sampler) {
  images_.push_back({width, height, rgba});
  nlohmann::json texture = {{"source", int(images_.size() - 1)}};
  if (!sampler.is_null() && !sampler.empty()) {
    samplers_.push_back(sampler);
    texture["sampler"] = int(samplers_.size() - 1);
  }
  textures_.push_back(texture);
  return int(textures_.size() - 1);
}

int GltfWriter::addMaterial(const nlohmann::json& material) {
  materials_.push_back(material);
  return int(materials_.size() - 1);
}

void GltfWriter::addQuad(const GltfQuad& quad) { quads_.push_back(quad); }

void GltfWriter::useExtension(const std::string& name, bool required) {
  used_.push_back(name);
  if (required) required_.push_back(name);
}

std::string GltfWriter::write(const std::string& dir, const std::string& name) const {
  std::vector<uint8_t> bin;
  nlohmann::json views = nlohmann::json::array(), accessors = nlohmann::json::array();
  nlohmann::json meshes = nlohmann::json::array(), nodes = nlohmann::json::array(), roots = nlohmann::json::array();
  auto accessor = [&](const void* data, size_t bytes, size_t count, const char* type, int componentType,
                      const nlohmann::json& extra = {}) {
    const size_t offset = append(bin, data, bytes);
    views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", bytes}});
    nlohmann::json a = {{"bufferView", int(views.size() - 1)}, {"componentType", componentType}, {"count", count},
                        {"type", type}};
    if (!extra.is_null()) a.update(extra);
    accessors.push_back(a);
    return int(accessors.size() - 1);
  };
  constexpr int kFloat = 5126, kUnsignedShort = 5123;
  for (const GltfQuad& q : quads_) {
    glm::vec3 lo = q.corners[0], hi = q.corners[0];
    for (const auto& c : q.corners) {
      lo = glm::min(lo, c);
      hi = glm::max(hi, c);
    }
    nlohmann::json attributes;
    attributes["POSITION"] = accessor(q.corners.data(), sizeof q.corners, 4, "VEC3", kFloat,
                                      {{"min", {lo.x, lo.y, lo.z}}, {"max", {hi.x, hi.y, hi.z}}});
    const glm::vec3 normal = glm::normalize(glm::cross(q.corners[1] - q.corners[0], q.corners[2] - q.corners[0]));
    const std::array<glm::vec3, 4> normals = {normal, normal, normal, normal};
    attributes["NORMAL"] = accessor(normals.data(), sizeof normals, 4, "VEC3", kFloat);
    attributes["TEXCOORD_0"] = accessor(q.uv.data(), sizeof q.uv, 4, "VEC2", kFloat);
    if (q.uv1) attributes["TEXCOORD_1"] = accessor(q.uv1->data(), sizeof *q.uv1, 4, "VEC2", kFloat);
    if (q.color) attributes["COLOR_0"] = accessor(q.color->data(), sizeof *q.color, 4, "VEC4", kFloat);
    const uint16_t indices[6] = {0, 1, 2, 0, 2, 3};
    nlohmann::json primitive = {{"attributes", attributes},
                                {"indices", accessor(indices, sizeof indices, 6, "SCALAR", kUnsignedShort)}};
    if (q.material >= 0) primitive["material"] = q.material;
    meshes.push_back({{"primitives", {primitive}}});
    nlohmann::json node = q.node;
    node["mesh"] = int(meshes.size() - 1);
    nodes.push_back(node);
    roots.push_back(int(nodes.size() - 1));
  }
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  nlohmann::json images = nlohmann::json::array();
  for (size_t i = 0; i < images_.size(); ++i) {
    const std::string file = name + "_" + std::to_string(i) + ".png";
    const Image& im = images_[i];
    if (stbi_write_png((fs::path(dir) / file).c_str(), im.width, im.height, 4, im.rgba.data(), im.width * 4) == 0)
      throw std::runtime_error("cannot write " + file);
    images.push_back({{"uri", file}});
  }
  {
    std::ofstream out(fs::path(dir) / (name + ".bin"), std::ios::binary);
    out.write(reinterpret_cast<const char*>(bin.data()), std::streamsize(bin.size()));
  }
  nlohmann::json gltf = {{"asset", {{"version", "2.0"}}},
                         {"scene", 0},
                         {"scenes", {{{"nodes", roots}}}},
                         {"nodes", nodes},
                         {"meshes", meshes},
                         {"accessors", accessors},
                         {"bufferViews", views},
                         {"buffers", {{{"uri", name + ".bin"}, {"byteLength", bin.size()}}}}};
  if (!materials_.empty()) gltf["materials"] = materials_;
  if (!textures_.empty()) gltf["textures"] = textures_;
  if (!images.empty()) gltf["images"] = images;
  if (!samplers_.empty()) gltf["samplers"] = samplers_;
  if (!used_.empty()) gltf["extensionsUsed"] = used_;
  if (!required_.empty()) gltf["extensionsRequired"] = required_;
  const std::string path = (fs::path(dir) / (name + ".gltf")).string();
  std::ofstream(path) << gltf.dump(1);
  return path;
}

std::string tempFolder(const std::string& prefix) {
  namespace fs = std::filesystem;
  std::string templ = (fs::temp_directory_path() / (prefix + "XXXXXX")).string();
  if (mkdtemp(templ.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  return templ;
}

GltfQuad quadFacingCamera(float x0, float y0, float x1, float y1, float z, int material) {
  GltfQuad q;
  q.corners = {glm::vec3(x0, y0, z), glm::vec3(x1, y0, z), glm::vec3(x1, y1, z), glm::vec3(x0, y1, z)};
  q.material = material;
  return q;
}

}  // namespace tally::testing

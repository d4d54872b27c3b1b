#include "scenes/gltf.hpp"
#include "scenes/gltf_check.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <thread>
#include <tuple>
#include <utility>

#include <stb_image.h>
#include <tiny_gltf.h>
#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

namespace tally::scenes {
namespace {

namespace fs = std::filesystem;
using tinygltf::Model;


// tinygltf calls this per image while parsing; we keep the encoded bytes and
// decode later on several threads (decoding is most of Sponza's load time).
bool keepEncoded(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                 const unsigned char* bytes, int size, void*) {
  image->image.assign(bytes, bytes + size);
  image->width = image->height = 0;  // not decoded yet
  return true;
}

std::string quote(const std::string& s) { return "\"" + s + "\""; }

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n') c = ';';
  return s;
}

// Reads `components` floats per element of an accessor. Normalized integer
// components are accepted where glTF allows them (texture coordinates).
Result<std::vector<float>> readFloats(const Model& model, int index, int components, bool allowNormalized,
                                      const std::string& what) {
  const std::string where = what + " (accessor " + std::to_string(index) + ")";
  if (index < 0 || size_t(index) >= model.accessors.size()) return makeError(where + ": no such accessor");
  const tinygltf::Accessor& acc = model.accessors[size_t(index)];
  if (acc.sparse.isSparse) return makeError(where + ": sparse accessors are not supported");
  if (tinygltf::GetNumComponentsInType(uint32_t(acc.type)) != components)
    return makeError(where + ": expected " + std::to_string(components) + " components per element");
  if (acc.bufferView < 0 || size_t(acc.bufferView) >= model.bufferViews.size())
    return makeError(where + ": has no buffer view (compressed or missing data)");
  const tinygltf::BufferView& view = model.bufferViews[size_t(acc.bufferView)];
  if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size())
    return makeError(where + ": buffer view refers to missing buffer " + std::to_string(view.buffer));
  const tinygltf::Buffer& buffer = model.buffers[size_t(view.buffer)];
  const int componentSize = tinygltf::GetComponentSizeInBytes(uint32_t(acc.componentType));
  const int stride = acc.ByteStride(view);
  if (componentSize <= 0 || stride <= 0) return makeError(where + ": invalid component type or stride");
  const size_t elementSize = size_t(componentSize) * size_t(components);
  const size_t start = view.byteOffset + acc.byteOffset;
  const size_t limit = std::min(view.byteOffset + view.byteLength, buffer.data.size());
  if (size_t(stride) < elementSize)
    return makeError(where + ": byteStride " + std::to_string(stride) + " is smaller than its element (" +
                     std::to_string(elementSize) + " bytes)");
  size_t span = 0;  // overflow-checked: a huge count must not wrap past the check and allocate
  if (acc.count > 0 && (__builtin_mul_overflow(size_t(stride), acc.count - 1, &span) ||
                        __builtin_add_overflow(span, start + elementSize, &span) || span > limit))
    return makeError(where + ": reads past the end of buffer " + std::to_string(view.buffer) +
                     (buffer.data.empty() ? " (the buffer has no data)" : ""));

  const int type = acc.componentType;
  const bool normalizedInt =
      allowNormalized && acc.normalized &&
      (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE || type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
  if (type != TINYGLTF_COMPONENT_TYPE_FLOAT && !normalizedInt)
    return makeError(where + ": unsupported component type " + std::to_string(type) +
                     (acc.normalized ? " (normalized)" : ""));

  std::vector<float> out(acc.count * size_t(components));
  const unsigned char* base = buffer.data.data() + start;
  for (size_t i = 0; i < acc.count; ++i) {
    const unsigned char* e = base + i * size_t(stride);
    for (int c = 0; c < components; ++c) {
      const unsigned char* p = e + size_t(c) * size_t(componentSize);
      float v = 0.0f;
      if (type == TINYGLTF_COMPONENT_TYPE_FLOAT) {
        std::memcpy(&v, p, 4);
      } else if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
        v = float(*p) / 255.0f;
      } else {
        uint16_t u16;
        std::memcpy(&u16, p, 2);
        v = float(u16) / 65535.0f;
      }
      out[i * size_t(components) + size_t(c)] = v;
    }
  }
  return out;
}

Result<std::vector<uint32_t>> readIndices(const Model& model, int index, size_t vertexCount,
                                          const std::string& what) {
  const std::string where = what + " indices (accessor " + std::to_string(index) + ")";
  if (index < 0 || size_t(index) >= model.accessors.size()) return makeError(where + ": no such accessor");
  const tinygltf::Accessor& acc = model.accessors[size_t(index)];
  if (acc.sparse.isSparse) return makeError(where + ": sparse accessors are not supported");
  size_t size = 0;
  switch (acc.componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: size = 1; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: size = 2; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: size = 4; break;
    default:
      return makeError(where + ": unsupported index component type " + std::to_string(acc.componentType) +
                       " (glTF allows unsigned byte, short or int)");
  }
  if (acc.type != TINYGLTF_TYPE_SCALAR) return makeError(where + ": indices must be scalars");
  if (acc.bufferView < 0 || size_t(acc.bufferView) >= model.bufferViews.size())
    return makeError(where + ": has no buffer view (compressed or missing data)");
  const tinygltf::BufferView& view = model.bufferViews[size_t(acc.bufferView)];
  if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size())
    return makeError(where + ": buffer view refers to missing buffer " + std::to_string(view.buffer));
  const tinygltf::Buffer& buffer = model.buffers[size_t(view.buffer)];
  const int stride = acc.ByteStride(view);
  if (stride <= 0) return makeError(where + ": invalid stride");
  const size_t start = view.byteOffset + acc.byteOffset;
  const size_t limit = std::min(view.byteOffset + view.byteLength, buffer.data.size());
  size_t span = 0;  // overflow-checked, as readFloats
  if (acc.count > 0 && (size_t(stride) < size || __builtin_mul_overflow(size_t(stride), acc.count - 1, &span) ||
                        __builtin_add_overflow(span, start + size, &span) || span > limit))
    return makeError(where + ": reads past the end of buffer " + std::to_string(view.buffer) +
                     (buffer.data.empty() ? " (the buffer has no data)" : ""));
  std::vector<uint32_t> out(acc.count);
  const unsigned char* base = buffer.data.data() + start;
  for (size_t i = 0; i < acc.count; ++i) {
    const unsigned char* p = base + i * size_t(stride);
    uint32_t v = 0;
    if (size == 1) v = *p;
    if (size == 2) {
      uint16_t s;
      std::memcpy(&s, p, 2);
      v = s;
    }
    if (size == 4) std::memcpy(&v, p, 4);
    if (v >= vertexCount)
      return makeError(where + ": index " + std::to_string(v) + " out of range (" +
                       std::to_string(vertexCount) + " vertices)");
    out[i] = v;
  }
  return out;
}

glm::mat4 localTransform(const tinygltf::Node& node) {
  if (node.matrix.size() == 16) {
    glm::dmat4 m = glm::make_mat4(node.matrix.data());  // column-major, as glTF stores it
    return glm::mat4(m);
  }
  glm::dmat4 t(1.0);
  if (node.translation.size() == 3) t = glm::translate(t, glm::make_vec3(node.translation.data()));
  if (node.rotation.size() == 4) {
    const auto& r = node.rotation;  // x, y, z, w
    t *= glm::mat4_cast(glm::dquat(r[3], r[0], r[1], r[2]));
  }
  if (node.scale.size() == 3) t = glm::scale(t, glm::make_vec3(node.scale.data()));
  return glm::mat4(t);
}

// Triangle-list indices for a primitive's mode; empty with ok = false for
// modes without triangles.
bool triangulate(int mode, const std::vector<uint32_t>& in, std::vector<uint32_t>* out) {
  out->clear();
  switch (mode) {
    case TINYGLTF_MODE_TRIANGLES:
      out->assign(in.begin(), in.begin() + long(in.size() - in.size() % 3));
      return true;
    case TINYGLTF_MODE_TRIANGLE_STRIP:
      for (size_t i = 2; i < in.size(); ++i) {
        if (i % 2 == 0)
          out->insert(out->end(), {in[i - 2], in[i - 1], in[i]});
        else
          out->insert(out->end(), {in[i - 1], in[i - 2], in[i]});
      }
      return true;
    case TINYGLTF_MODE_TRIANGLE_FAN:
      for (size_t i = 2; i < in.size(); ++i) out->insert(out->end(), {in[0], in[i - 1], in[i]});
      return true;
    default: return false;
  }
}

glm::vec3 anyOrthogonal(const glm::vec3& n) {
  glm::vec3 axis = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(axis - n * glm::dot(n, axis));
}

void computeNormals(Mesh& mesh) {
  std::vector<glm::vec3> acc(mesh.vertices.size(), glm::vec3(0.0f));
  for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    uint32_t a = mesh.indices[i], b = mesh.indices[i + 1], c = mesh.indices[i + 2];
    glm::vec3 n = glm::cross(mesh.vertices[b].position - mesh.vertices[a].position,
                             mesh.vertices[c].position - mesh.vertices[a].position);  // area-weighted
    acc[a] += n;
    acc[b] += n;
    acc[c] += n;
  }
  for (size_t i = 0; i < acc.size(); ++i) {
    float len = glm::length(acc[i]);
    mesh.vertices[i].normal = len > 0.0f ? acc[i] / len : glm::vec3(0, 1, 0);
  }
}

// One texture of the scene: a glTF image in a colour space through a sampler.
struct ImageUse {
  int image;
  bool srgb;
  Sampler sampler;
  bool operator<(const ImageUse& o) const {
    return std::tie(image, srgb, sampler) < std::tie(o.image, o.srgb, o.sampler);
  }
};

// glTF sampler enums (KHR's OpenGL values) -> Sampler; unknown values are errors.
Result<Sampler> samplerOf(const tinygltf::Sampler& s, const std::string& what) {
  Sampler out;
  auto wrap = [&](int v, Wrap* into, const char* axis) -> std::optional<Error> {
    switch (v) {
      case -1:
      case TINYGLTF_TEXTURE_WRAP_REPEAT: *into = Wrap::Repeat; return std::nullopt;
      case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT: *into = Wrap::MirroredRepeat; return std::nullopt;
      case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE: *into = Wrap::ClampToEdge; return std::nullopt;
      default: return makeError(what + ": " + axis + " " + std::to_string(v) + " is not a glTF wrap mode");
    }
  };
  if (auto e = wrap(s.wrapS, &out.wrapU, "wrapS")) return *e;
  if (auto e = wrap(s.wrapT, &out.wrapV, "wrapT")) return *e;
  switch (s.magFilter) {
    case -1:
    case TINYGLTF_TEXTURE_FILTER_LINEAR: out.mag = Filter::Linear; break;
    case TINYGLTF_TEXTURE_FILTER_NEAREST: out.mag = Filter::Nearest; break;
    default: return makeError(what + ": magFilter " + std::to_string(s.magFilter) + " is not a glTF filter");
  }
  switch (s.minFilter) {
    case -1:
    case TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR: break;  // the default: trilinear
    case TINYGLTF_TEXTURE_FILTER_NEAREST: out.min = Filter::Nearest; out.mipmaps = false; break;
    case TINYGLTF_TEXTURE_FILTER_LINEAR: out.mipmaps = false; break;
    case TINYGLTF_TEXTURE_FILTER_NEAREST_MIPMAP_NEAREST: out.min = out.mip = Filter::Nearest; break;
    case TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_NEAREST: out.mip = Filter::Nearest; break;
    case TINYGLTF_TEXTURE_FILTER_NEAREST_MIPMAP_LINEAR: out.min = Filter::Nearest; break;
    default: return makeError(what + ": minFilter " + std::to_string(s.minFilter) + " is not a glTF filter");
  }
  return out;
}

// A textureInfo's uv set and KHR_texture_transform (whose texCoord overrides).
struct TextureRef {
  int index = -1;
  int texCoord = 0;
  UvTransform transform;
};
Result<TextureRef> textureRef(int index, int texCoord, const tinygltf::ExtensionMap& extensions,
                              const std::string& what) {
  TextureRef r{index, texCoord, {}};
  auto ext = extensions.find("KHR_texture_transform");
  if (ext != extensions.end() && ext->second.IsObject()) {
    const tinygltf::Value& t = ext->second;
    auto numbers = [&](const char* key, size_t n, float* out) -> std::optional<Error> {
      const tinygltf::Value& v = t.Get(key);
      if (!v.IsArray()) return std::nullopt;
      if (v.ArrayLen() != n) return makeError(what + ": KHR_texture_transform " + key + " must have " + std::to_string(n) + " numbers");
      for (size_t i = 0; i < n; ++i) {
        const tinygltf::Value& x = v.Get(int(i));
        if (!x.IsNumber()) return makeError(what + ": KHR_texture_transform " + key + " must be numbers");
        out[i] = float(x.GetNumberAsDouble());
        if (!std::isfinite(out[i])) return makeError(what + ": KHR_texture_transform " + key + " is not finite");
      }
      return std::nullopt;
    };
    if (auto e = numbers("offset", 2, &r.transform.offset.x)) return *e;
    if (auto e = numbers("scale", 2, &r.transform.scale.x)) return *e;
    if (t.Has("rotation")) {
      if (!t.Get("rotation").IsNumber()) return makeError(what + ": KHR_texture_transform rotation must be a number");
      r.transform.rotation = float(t.Get("rotation").GetNumberAsDouble());
      if (!std::isfinite(r.transform.rotation)) return makeError(what + ": KHR_texture_transform rotation is not finite");
    }
    if (t.Has("texCoord") && t.Get("texCoord").IsInt()) r.texCoord = t.Get("texCoord").GetNumberAsInt();
  }
  if (r.index >= 0 && (r.texCoord < 0 || r.texCoord > 1)) {
    return makeError(what + ": texCoord " + std::to_string(r.texCoord) +
                     " is not supported (Tally reads TEXCOORD_0 and TEXCOORD_1)");
  }
  return r;
}

struct Loader {
  const GltfOptions& options;
  Model model;
  Scene scene;
  std::map<ImageUse, int32_t> textureOf;  // -> index in scene.textures
  std::vector<ImageUse> uses;             // in scene.textures order
  int32_t defaultMaterial = -1;

  std::string meshName(int meshIndex, size_t primitive) const {
    const tinygltf::Mesh& m = model.meshes[size_t(meshIndex)];
    std::string name = m.name.empty() ? "mesh " + std::to_string(meshIndex) : m.name;
    if (m.primitives.size() > 1) name += "#" + std::to_string(primitive);
    return name;
  }

  // Texture slot for a glTF texture index (or -1).
  Result<int32_t> texture(int gltfTexture, bool srgb, const std::string& what) {
    if (gltfTexture < 0) return int32_t(-1);
    if (size_t(gltfTexture) >= model.textures.size())
      return makeError(what + ": texture " + std::to_string(gltfTexture) + " does not exist");
    Sampler sampler;
    const int samplerIndex = model.textures[size_t(gltfTexture)].sampler;
    if (samplerIndex >= 0) {
      if (size_t(samplerIndex) >= model.samplers.size())
        return makeError(what + ": sampler " + std::to_string(samplerIndex) + " does not exist");
      Result<Sampler> s = samplerOf(model.samplers[size_t(samplerIndex)], "sampler " + std::to_string(samplerIndex));
      if (!s) return makeError(s.error());
      sampler = *s;
    }
    int image = model.textures[size_t(gltfTexture)].source;
    if (image < 0) {
      scene.notes.push_back(what + ": texture " + std::to_string(gltfTexture) +
                            " has no image; using the dummy");
      return int32_t(-1);
    }
    if (size_t(image) >= model.images.size())
      return makeError(what + ": image " + std::to_string(image) + " does not exist");
    ImageUse use{image, srgb, sampler};
    auto it = textureOf.find(use);
    if (it != textureOf.end()) return it->second;
    int32_t index = int32_t(uses.size());
    uses.push_back(use);
    textureOf[use] = index;
    return index;
  }

  Result<bool> loadMaterials() {
    for (size_t i = 0; i < model.materials.size(); ++i) {
      const tinygltf::Material& g = model.materials[i];
      const std::string what = "material " + std::to_string(i) + (g.name.empty() ? "" : " (" + g.name + ")");
      Material m;
      m.name = g.name.empty() ? "material " + std::to_string(i) : g.name;
      const auto& pbr = g.pbrMetallicRoughness;
      if (pbr.baseColorFactor.size() == 4)
        m.baseColor = glm::vec4(pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2],
                                pbr.baseColorFactor[3]);
      m.roughness = float(pbr.roughnessFactor);
      m.metallic = float(pbr.metallicFactor);
      m.alphaMode = g.alphaMode == "MASK"    ? AlphaMode::Mask
                    : g.alphaMode == "BLEND" ? AlphaMode::Blend
                                             : AlphaMode::Opaque;
      m.alphaCutoff = float(g.alphaCutoff);

      m.doubleSided = g.doubleSided;
      if (g.emissiveFactor.size() == 3)
        m.emissiveFactor = glm::vec3(g.emissiveFactor[0], g.emissiveFactor[1], g.emissiveFactor[2]);
      auto strength = g.extensions.find("KHR_materials_emissive_strength");
      if (strength != g.extensions.end() && strength->second.Get("emissiveStrength").IsNumber())
        m.emissiveFactor *= float(strength->second.Get("emissiveStrength").GetNumberAsDouble());
      if (!std::isfinite(m.emissiveFactor.x + m.emissiveFactor.y + m.emissiveFactor.z))
        return makeError(what + ": emissiveFactor is not finite");
      int specular = -1;
      int specularTexCoord = 0;
      tinygltf::ExtensionMap specularExtensions;
      bool specularSrgb = false;
      auto ext = g.extensions.find("KHR_materials_specular");
      if (ext != g.extensions.end() && ext->second.IsObject()) {
        const tinygltf::Value& color = ext->second.Get("specularColorTexture");
        const tinygltf::Value& texture = ext->second.Get("specularTexture");
        const tinygltf::Value& used = color.IsObject() && color.Get("index").IsInt() ? color : texture;
        if (used.IsObject() && used.Get("index").IsInt()) {
          specular = used.Get("index").GetNumberAsInt();
          specularSrgb = &used == &color;
          if (used.Get("texCoord").IsInt()) specularTexCoord = used.Get("texCoord").GetNumberAsInt();
        }
      }
      struct Source {
        MapSlot slot;
        int index, texCoord;
        const tinygltf::ExtensionMap* extensions;
        bool srgb;
      };
      const Source slots[] = {
          {MapSlot::Diffuse, pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord,
           &pbr.baseColorTexture.extensions, true},
          {MapSlot::Ambient, g.occlusionTexture.index, g.occlusionTexture.texCoord, &g.occlusionTexture.extensions,
           false},
          {MapSlot::Specular, specular, specularTexCoord, &specularExtensions, specularSrgb},
          {MapSlot::Roughness, pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord,
           &pbr.metallicRoughnessTexture.extensions, false},
          {MapSlot::Normal, g.normalTexture.index, g.normalTexture.texCoord, &g.normalTexture.extensions, false},
      };
      for (const Source& source : slots) {
        const std::string map = what + " " + toString(source.slot);
        Result<TextureRef> ref = textureRef(source.index, source.texCoord, *source.extensions, map);
        if (!ref) return makeError(ref.error());
        Result<int32_t> t = texture(ref->index, source.srgb, map);
        if (!t) return makeError(t.error());
        m.maps[size_t(source.slot)] = *t;
        m.texCoord[size_t(source.slot)] = uint32_t(ref->texCoord);
        m.transform[size_t(source.slot)] = ref->transform;
      }
      {
        Result<TextureRef> ref = textureRef(g.emissiveTexture.index, g.emissiveTexture.texCoord,
                                            g.emissiveTexture.extensions, what + " emissive");
        if (!ref) return makeError(ref.error());
        Result<int32_t> t = texture(ref->index, true, what + " emissive");
        if (!t) return makeError(t.error());
        m.emissiveMap = *t;
        m.emissiveTexCoord = uint32_t(ref->texCoord);
        m.emissiveTransform = ref->transform;
      }
      scene.materials.push_back(std::move(m));
    }
    return true;
  }

  Result<bool> addPrimitive(int meshIndex, size_t p, const glm::mat4& transform) {
    const tinygltf::Primitive& prim = model.meshes[size_t(meshIndex)].primitives[p];
    const std::string what = "mesh " + quote(meshName(meshIndex, p));
    auto attribute = [&](const char* name) {
      auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    // tinygltf leaves an absent mode at -1; glTF's default is triangles.
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN) {
      static const char* kModes[] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP"};
      return makeError(what + " primitive " + std::to_string(p) + ": mode " + std::to_string(mode) +
                       (mode >= 0 && mode < 4 ? std::string(" (") + kModes[mode] + ")" : std::string()) +
                       " is not drawn: Tally renders triangles only, and refuses rather than drop them");
    }
    if (attribute("POSITION") < 0) return makeError(what + ": primitive has no POSITION attribute");
    Result<std::vector<float>> pos = readFloats(model, attribute("POSITION"), 3, false, what + " POSITION");
    if (!pos) return makeError(pos.error());
    const size_t n = pos->size() / 3;
    for (size_t i = 0; i < pos->size(); ++i) {
      if (!std::isfinite((*pos)[i]))
        return makeError(what + " POSITION (accessor " + std::to_string(attribute("POSITION")) + "): vertex " +
                         std::to_string(i / 3) + " is not finite (" + std::to_string((*pos)[i]) + ")");
    }
    std::vector<float> nrm, uv, tan, uv1;
    for (auto [name, comps, into, normalized] :
         {std::tuple{"NORMAL", 3, &nrm, false}, std::tuple{"TEXCOORD_0", 2, &uv, true},
          std::tuple{"TANGENT", 4, &tan, false}, std::tuple{"TEXCOORD_1", 2, &uv1, true}}) {
      if (attribute(name) < 0) continue;
      Result<std::vector<float>> r = readFloats(model, attribute(name), comps, normalized, what + " " + name);
      if (!r) return makeError(r.error());
      if (r->size() / size_t(comps) != n)
        return makeError(what + ": " + name + " count differs from POSITION count");
      *into = std::move(*r);
    }
    std::vector<uint32_t> raw;
    if (prim.indices >= 0) {
      Result<std::vector<uint32_t>> idx = readIndices(model, prim.indices, n, what);
      if (!idx) return makeError(idx.error());
      raw = std::move(*idx);
    } else {
      raw.resize(n);
      for (uint32_t i = 0; i < n; ++i) raw[i] = i;
    }

    std::vector<float> colors;  // COLOR_0 as RGBA
    if (attribute("COLOR_0") >= 0) {
      const int index = attribute("COLOR_0");
      const int components = size_t(index) < model.accessors.size() && model.accessors[size_t(index)].type == TINYGLTF_TYPE_VEC3 ? 3 : 4;
      Result<std::vector<float>> r = readFloats(model, index, components, true, what + " COLOR_0");
      if (!r) return makeError(r.error());
      if (r->size() / size_t(components) != n) return makeError(what + ": COLOR_0 count differs from POSITION count");
      colors.resize(n * 4, 1.0f);
      for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < components; ++c) colors[i * 4 + size_t(c)] = (*r)[i * size_t(components) + size_t(c)];
    }
    Mesh mesh;
    mesh.name = meshName(meshIndex, p);
    if (prim.material >= 0) {
      if (size_t(prim.material) >= model.materials.size())
        return makeError(what + ": material " + std::to_string(prim.material) + " does not exist");
      mesh.material = uint32_t(prim.material);
    } else {
      if (defaultMaterial < 0) {
        defaultMaterial = int32_t(scene.materials.size());
        Material m;
        m.name = "default";
        scene.materials.push_back(m);
      }
      mesh.material = uint32_t(defaultMaterial);
    }
    triangulate(mode, raw, &mesh.indices);
    const float det = glm::determinant(glm::mat3(transform));
    if (det < 0.0f)  // a mirroring transform flips the winding; restore counter-clockwise fronts
      for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3)
        std::swap(mesh.indices[i + 1], mesh.indices[i + 2]);
    const glm::mat3 normalMatrix = glm::inverseTranspose(glm::mat3(transform));
    mesh.vertices.resize(n);
    for (size_t i = 0; i < n; ++i) {
      Vertex& v = mesh.vertices[i];
      v.position =
          glm::vec3(transform * glm::vec4(pos->at(3 * i), pos->at(3 * i + 1), pos->at(3 * i + 2), 1.0f));
      if (!nrm.empty()) {
        glm::vec3 nn = normalMatrix * glm::vec3(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]);
        float len = glm::length(nn);
        v.normal = len > 0.0f && std::isfinite(len) ? nn / len : glm::vec3(0, 1, 0);
      }
      if (!uv.empty()) v.uv = glm::vec2(uv[2 * i], uv[2 * i + 1]);
      if (!tan.empty()) {
        glm::vec3 t = glm::mat3(transform) * glm::vec3(tan[4 * i], tan[4 * i + 1], tan[4 * i + 2]);
        t -= v.normal * glm::dot(v.normal, t);
        float len = glm::length(t);
        float w = (tan[4 * i + 3] < 0.0f ? -1.0f : 1.0f) * (det < 0.0f ? -1.0f : 1.0f);
        v.tangent =
            len > 1e-6f && std::isfinite(len) ? glm::vec4(t / len, w) : glm::vec4(anyOrthogonal(v.normal), w);
      }
    }
    if (mesh.material < scene.materials.size() && uv1.empty()) {
      const Material& mat = scene.materials[mesh.material];
      bool wantsUv1 = mat.emissiveMap >= 0 && mat.emissiveTexCoord == 1;
      for (size_t k = 0; k < kMapSlotCount; ++k) wantsUv1 = wantsUv1 || (mat.maps[k] >= 0 && mat.texCoord[k] == 1);
      if (wantsUv1)
        scene.notes.push_back(what + ": material \"" + mat.name +
                              "\" samples TEXCOORD_1, which the mesh lacks; TEXCOORD_0 is used instead");
    }
    for (size_t i = 0; i < colors.size() / 4; ++i)
      mesh.colors.emplace_back(colors[4 * i], colors[4 * i + 1], colors[4 * i + 2], colors[4 * i + 3]);
    for (size_t i = 0; i < uv1.size() / 2; ++i) mesh.uv1.emplace_back(uv1[2 * i], uv1[2 * i + 1]);
    if (nrm.empty()) computeNormals(mesh);
    if (tan.empty()) computeTangents(mesh);
    updateBounds(mesh);
    if (!mesh.indices.empty()) scene.meshes.push_back(std::move(mesh));
    return true;
  }

  Result<bool> addNode(int nodeIndex, const glm::mat4& parent, int depth) {
    if (nodeIndex < 0 || size_t(nodeIndex) >= model.nodes.size())
      return makeError("node " + std::to_string(nodeIndex) + " does not exist");
    if (depth > 256)
      return makeError("node hierarchy deeper than 256 levels (a cycle?) at node " +
                       std::to_string(nodeIndex));
    const tinygltf::Node& node = model.nodes[size_t(nodeIndex)];
    const glm::mat4 world = parent * localTransform(node);
    if (node.mesh >= 0) {
      if (size_t(node.mesh) >= model.meshes.size())
        return makeError("node " + std::to_string(nodeIndex) + ": mesh " + std::to_string(node.mesh) +
                         " does not exist");
      for (size_t p = 0; p < model.meshes[size_t(node.mesh)].primitives.size(); ++p) {
        Result<bool> r = addPrimitive(node.mesh, p, world);
        if (!r) return r;
      }
    }
    for (int child : node.children) {
      Result<bool> r = addNode(child, world, depth + 1);
      if (!r) return r;
    }
    return true;
  }

  Result<bool> loadNodes() {
    std::vector<int> roots;
    if (!model.scenes.empty()) {
      size_t s = model.defaultScene >= 0 && size_t(model.defaultScene) < model.scenes.size()
                     ? size_t(model.defaultScene)
                     : 0;
      roots = model.scenes[s].nodes;
    } else {
      // No scene: every node that is nobody's child is a root.
      std::vector<bool> isChild(model.nodes.size(), false);
      for (const auto& n : model.nodes)
        for (int c : n.children)
          if (c >= 0 && size_t(c) < isChild.size()) isChild[size_t(c)] = true;
      for (size_t i = 0; i < model.nodes.size(); ++i)
        if (!isChild[i]) roots.push_back(int(i));
    }
    for (int r : roots) {
      Result<bool> ok = addNode(r, glm::mat4(1.0f), 0);
      if (!ok) return ok;
    }
    return true;
  }

  std::string imageName(int image) const {
    const tinygltf::Image& im = model.images[size_t(image)];
    if (!im.name.empty()) return im.name;
    if (!im.uri.empty()) return im.uri;
    return "image " + std::to_string(image);
  }

  // Decodes each used image once, on several threads, then downsizes.
  Result<bool> decodeTextures() {
    std::vector<int> images;
    for (const ImageUse& u : uses)
      if (std::find(images.begin(), images.end(), u.image) == images.end()) images.push_back(u.image);
    std::vector<Texture> decoded(images.size());
    std::vector<std::string> errors(images.size());
    std::atomic<size_t> next{0};
    auto work = [&] {
      for (size_t k = next++; k < images.size(); k = next++) {
        const tinygltf::Image& im = model.images[size_t(images[k])];
        if (im.image.empty()) {
          errors[k] = "image " + std::to_string(images[k]) + " (" + imageName(images[k]) +
                      "): no data (file missing or unreadable)";
          continue;
        }
        int w = 0, h = 0, comp = 0;
        // The header's size first: a decoded image is w x h x 4 bytes.
        if (stbi_info_from_memory(im.image.data(), int(im.image.size()), &w, &h, &comp) &&
            (uint32_t(w) > kMaxImageSide || uint32_t(h) > kMaxImageSide ||
             uint64_t(w) * uint64_t(h) > kMaxImageTexels)) {
          errors[k] = "image " + std::to_string(images[k]) + " (" + imageName(images[k]) + "): " + std::to_string(w) +
                      "x" + std::to_string(h) + " texels, over Tally's limit of " + std::to_string(kMaxImageSide) +
                      " per side";
          continue;
        }
        stbi_uc* px = stbi_load_from_memory(im.image.data(), int(im.image.size()), &w, &h, &comp, 4);
        if (!px) {
          errors[k] =
              "image " + std::to_string(images[k]) + " (" + imageName(images[k]) +
              "): cannot decode: " + (stbi_failure_reason() ? stbi_failure_reason() : "unknown format");
          continue;
        }
        Texture& t = decoded[k];
        t.width = uint32_t(w);
        t.height = uint32_t(h);
        t.rgba8.assign(px, px + size_t(w) * size_t(h) * 4);
        stbi_image_free(px);
        if (options.maxTextureSize > 0) downsize(t, options.maxTextureSize);
      }
    };
    unsigned threads = options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
    threads = unsigned(std::min<size_t>(threads, images.size()));
    std::vector<std::thread> pool;
    for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work);
    work();
    for (std::thread& t : pool) t.join();
    for (const std::string& e : errors)
      if (!e.empty()) return makeError(e);

    for (const ImageUse& u : uses) {
      size_t k = size_t(std::find(images.begin(), images.end(), u.image) - images.begin());
      Texture t;
      t.name = imageName(u.image);
      t.width = decoded[k].width;
      t.height = decoded[k].height;
      t.srgb = u.srgb;
      t.sampler = u.sampler;
      t.rgba8 = decoded[k].rgba8;  // copies only when an image is used in both colour spaces
      scene.textures.push_back(std::move(t));
    }
    return true;
  }

  // Halves with a 2x2 box filter until neither side exceeds maxSize.
  static void downsize(Texture& t, uint32_t maxSize) {
    while (t.width > maxSize || t.height > maxSize) {
      uint32_t w = std::max(1u, t.width / 2), h = std::max(1u, t.height / 2);
      std::vector<uint8_t> out(size_t(w) * h * 4);
      for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
          uint32_t x0 = std::min(2 * x, t.width - 1), x1 = std::min(2 * x + 1, t.width - 1);
          uint32_t y0 = std::min(2 * y, t.height - 1), y1 = std::min(2 * y + 1, t.height - 1);
          for (int c = 0; c < 4; ++c) {
            auto at = [&](uint32_t xx, uint32_t yy) {
              return uint32_t(t.rgba8[(size_t(yy) * t.width + xx) * 4 + size_t(c)]);
            };
            out[(size_t(y) * w + x) * 4 + size_t(c)] =
                uint8_t((at(x0, y0) + at(x1, y0) + at(x0, y1) + at(x1, y1) + 2) / 4);
          }
        }
      t.width = w;
      t.height = h;
      t.rgba8 = std::move(out);
    }
  }
};

}  // namespace

Result<Scene> loadGltf(const std::string& path, const GltfOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return makeError(quote(path) + ": file not found");
  if (!fs::is_regular_file(path, ec)) return makeError(quote(path) + ": not a regular file");
  char magic[4] = {};
  {
    std::ifstream f(path, std::ios::binary);
    if (!f) return makeError(quote(path) + ": cannot open");
    f.read(magic, 4);
  }
  const bool binary = std::memcmp(magic, "glTF", 4) == 0;

  // Extensions, ranges and the node graph's instance counts, before tinygltf
  // reads any buffer or image (gltf_check.hpp).
  Result<GltfPrecheck> precheck = precheckGltf(path);
  if (!precheck) return makeError(quote(path) + ": " + precheck.error());

  Loader loader{options, {}, {}, {}, {}, -1};
  loader.scene.notes = precheck->notes;
  tinygltf::TinyGLTF gltf;
  gltf.SetImageLoader(keepEncoded, nullptr);
  std::string err, warn;
  bool ok = binary ? gltf.LoadBinaryFromFile(&loader.model, &err, &warn, path)
                   : gltf.LoadASCIIFromFile(&loader.model, &err, &warn, path);
  if (!ok) return makeError(quote(path) + ": not a valid glTF file: " + trimmed(err.empty() ? warn : err));
  if (!warn.empty()) loader.scene.notes.push_back("tinygltf: " + trimmed(warn));


  Result<bool> r = loader.loadMaterials();
  if (r) r = loader.loadNodes();
  if (r && !options.geometryOnly) r = loader.decodeTextures();
  if (!r) return makeError(quote(path) + ": " + r.error());
  if (loader.scene.meshes.empty()) return makeError(quote(path) + ": no triangles in the default scene");

  Scene& scene = loader.scene;
  scene.name = fs::path(path).stem().string();
  updateBounds(scene);
  scene.params = {{"gltf", path}};
  if (options.maxTextureSize > 0) scene.params["max_texture_size"] = options.maxTextureSize;
  return std::move(scene);
}

}  // namespace tally::scenes

// Materials: glTF's metallic-roughness maps and extensions onto Tally's map
// slots, their samplers, texture coordinates and KHR_texture_transform, and
// one scene texture per (image, colour space, sampler) they use.
#include "scenes/gltf_loader.hpp"

#include <cmath>
#include <optional>

namespace tally::scenes::detail {
namespace {

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

}  // namespace

Result<int32_t> Loader::texture(int gltfTexture, bool srgb, const std::string& what) {
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

Result<bool> Loader::loadMaterials() {
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

}  // namespace tally::scenes::detail

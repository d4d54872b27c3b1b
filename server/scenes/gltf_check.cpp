#include "scenes/gltf_check.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <utility>

#include <nlohmann/json.hpp>

namespace tally::scenes {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr uint64_t kSaturated = ~uint64_t(0);
constexpr uint64_t kMaxJsonBytes = 1ull << 30;  // a .gltf or a .glb JSON chunk: 1 GiB

uint64_t addSat(uint64_t a, uint64_t b) { return a > kSaturated - b ? kSaturated : a + b; }
uint64_t mulSat(uint64_t a, uint64_t b) { return b != 0 && a > kSaturated / b ? kSaturated : a * b; }

// Extensions Tally draws, and what it does with the others it meets.
const std::set<std::string> kImplemented = {
    "KHR_texture_transform",            // per map
    "KHR_materials_emissive_strength",  // multiplies emissiveFactor
    "KHR_materials_specular",           // its texture is the specular map (Blinn-Phong colour)
};
const std::map<std::string, std::string> kCompressed = {
    {"KHR_draco_mesh_compression", "its geometry is compressed with KHR_draco_mesh_compression"},
    {"EXT_meshopt_compression", "its buffers are compressed with EXT_meshopt_compression"},
    {"KHR_mesh_quantization", "its geometry is quantized with KHR_mesh_quantization"},
};
// What is not drawn when an extension is used but not required.
const std::map<std::string, std::string> kIgnored = {
    {"KHR_materials_clearcoat", "clearcoat is not drawn"},
    {"KHR_materials_transmission", "transmissive materials are drawn opaque"},
    {"KHR_materials_sheen", "sheen is not drawn"},
    {"KHR_materials_volume", "volume attenuation is not drawn"},
    {"KHR_materials_ior", "the index of refraction is ignored"},
    {"KHR_materials_iridescence", "iridescence is not drawn"},
    {"KHR_materials_anisotropy", "anisotropy is not drawn"},
    {"KHR_materials_dispersion", "dispersion is not drawn"},
    {"KHR_materials_unlit", "unlit materials are drawn lit"},
    {"KHR_materials_variants", "the default material of each primitive is drawn"},
    {"KHR_materials_pbrSpecularGlossiness", "the metallic-roughness fallback is drawn"},
    {"KHR_lights_punctual", "the file's lights are ignored: Tally lights every scene with its own point lights"},
    {"KHR_texture_basisu", "the fallback PNG or JPEG image is drawn"},
    {"EXT_texture_webp", "the fallback PNG or JPEG image is drawn"},
    {"MSFT_texture_dds", "the fallback PNG or JPEG image is drawn"},
    {"EXT_mesh_gpu_instancing", "the mesh is drawn once per node, not per instance"},
    {"KHR_animation_pointer", "animation is not played"},
};

int componentBytes(int type) {
  switch (type) {
    case 5120:
    case 5121: return 1;
    case 5122:
    case 5123: return 2;
    case 5125:
    case 5126: return 4;
    default: return 0;
  }
}
int componentsOf(const std::string& type) {
  static const std::map<std::string, int> kTypes = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                                                    {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
  auto it = kTypes.find(type);
  return it == kTypes.end() ? 0 : it->second;
}

// A non-negative integer field, or `dflt` when absent; nullopt when malformed.
std::optional<uint64_t> unsignedField(const json& o, const char* key, uint64_t dflt) {
  if (!o.contains(key)) return dflt;
  const json& v = o[key];
  if (v.is_number_unsigned()) return v.get<uint64_t>();
  if (v.is_number_integer() && v.get<int64_t>() >= 0) return uint64_t(v.get<int64_t>());
  return std::nullopt;
}

// Typed reads that never throw: a field of the wrong type (or an element
// that is not an object) reads as `dflt`, and the checks below refuse it.
int64_t intField(const json& o, const char* key, int64_t dflt) {
  if (!o.is_object() || !o.contains(key) || !o[key].is_number_integer()) return dflt;
  return o[key].is_number_unsigned() && o[key].get<uint64_t>() > uint64_t(INT64_MAX) ? dflt
                                                                                     : o[key].get<int64_t>();
}

std::string stringField(const json& o, const char* key) {
  return o.is_object() && o.contains(key) && o[key].is_string() ? o[key].get<std::string>() : std::string();
}

json objectField(const json& o, const char* key) {
  return o.is_object() && o.contains(key) && o[key].is_object() ? o[key] : json::object();
}

json fieldOrNull(const json& o, const char* key) {
  return o.is_object() && o.contains(key) ? o[key] : json();
}

std::string percentDecoded(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(uint8_t(s[i + 1])) && std::isxdigit(uint8_t(s[i + 2]))) {
      out += char(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

struct Source {
  json doc;
  uint64_t binChunk = 0;  // .glb: bytes of the BIN chunk
  bool glb = false;
};

Result<Source> readSource(const std::string& path) {
  std::error_code ec;
  const uint64_t size = fs::file_size(path, ec);
  if (ec) return makeError("cannot read its size: " + ec.message());
  std::ifstream f(path, std::ios::binary);
  if (!f) return makeError("cannot open");
  char magic[4] = {};
  f.read(magic, 4);
  Source src;
  std::string text;
  if (f.gcount() == 4 && std::memcmp(magic, "glTF", 4) == 0) {
    src.glb = true;
    uint32_t header[2] = {};  // version, length
    f.read(reinterpret_cast<char*>(header), 8);
    if (f.gcount() != 8) return makeError("truncated .glb header (12 bytes expected)");
    if (header[0] != 2) return makeError(".glb version " + std::to_string(header[0]) + " (glTF 2.0 needs 2)");
    if (header[1] > size)
      return makeError(".glb header length " + std::to_string(header[1]) + " exceeds the file's " +
                       std::to_string(size) + " bytes (truncated file?)");
    uint64_t offset = 12;
    for (int chunk = 0; offset + 8 <= header[1]; ++chunk) {
      uint32_t head[2] = {};  // length, type
      f.seekg(std::streamoff(offset));
      f.read(reinterpret_cast<char*>(head), 8);
      if (f.gcount() != 8) return makeError(".glb chunk " + std::to_string(chunk) + ": truncated header");
      if (offset + 8 + head[0] > header[1])
        return makeError(".glb chunk " + std::to_string(chunk) + ": length " + std::to_string(head[0]) +
                         " runs past the end of the file (" + std::to_string(header[1]) + " bytes)");
      if (chunk == 0) {
        if (head[1] != 0x4E4F534A) return makeError(".glb chunk 0 is not JSON");
        if (head[0] > kMaxJsonBytes) return makeError(".glb JSON chunk larger than 1 GiB");
        text.resize(head[0]);
        f.read(text.data(), std::streamsize(head[0]));
      } else if (head[1] == 0x004E4942 && src.binChunk == 0) {
        src.binChunk = head[0];
      }
      offset += 8 + uint64_t(head[0]);
    }
    if (text.empty()) return makeError(".glb has no JSON chunk");
  } else {
    if (size > kMaxJsonBytes) return makeError("a .gltf larger than 1 GiB");
    text.resize(size);
    f.seekg(0);
    f.read(text.data(), std::streamsize(size));
  }
  try {
    src.doc = json::parse(text);
  } catch (const json::exception& e) {
    std::string what = e.what();
    return makeError("invalid JSON: " + what.substr(what.find(']') == std::string::npos ? 0 : what.find(']') + 2));
  }
  if (!src.doc.is_object()) return makeError("invalid glTF: the top level is not an object");
  return src;
}

// The bytes behind buffer i: the .glb's BIN chunk, a data URI, or a file.
Result<uint64_t> bufferData(const Source& src, const json& buffer, size_t i, const fs::path& folder) {
  if (!buffer.contains("uri")) {
    if (src.glb && i == 0) return src.binChunk;
    return makeError("buffer " + std::to_string(i) + ": no uri and no .glb BIN chunk");
  }
  if (!buffer["uri"].is_string()) return makeError("buffer " + std::to_string(i) + ": uri is not a string");
  const std::string uri = buffer["uri"].get<std::string>();
  if (uri.rfind("data:", 0) == 0) {
    const size_t comma = uri.find(',');
    if (comma == std::string::npos) return makeError("buffer " + std::to_string(i) + ": malformed data URI");
    return uint64_t(uri.size() - comma - 1) / 4 * 3;  // base64: 3 bytes per 4 characters (padding aside)
  }
  std::error_code ec;
  fs::path file = folder / uri;
  if (!fs::exists(file, ec)) file = folder / percentDecoded(uri);
  const uint64_t size = fs::file_size(file, ec);
  if (ec) return makeError("buffer " + std::to_string(i) + ": file \"" + uri + "\" not found or unreadable");
  return size;
}

struct MeshCost {
  uint64_t primitives = 0, triangles = 0, vertices = 0;
};

using Sizes = std::vector<uint64_t>;

void add(MeshCost& into, const MeshCost& more) {
  into.primitives = addSat(into.primitives, more.primitives);
  into.triangles = addSat(into.triangles, more.triangles);
  into.vertices = addSat(into.vertices, more.vertices);
}

// The document's array `key`, or an empty one.
const json& arrayOf(const json& doc, const char* key) {
  static const json kEmpty = json::array();
  return doc.contains(key) && doc[key].is_array() ? doc[key] : kEmpty;
}

// Extensions: the required ones must be implemented; the used ones that are
// not become notes saying what is not drawn.
Result<std::vector<std::string>> checkExtensions(const json& doc) {
  std::vector<std::string> notes;
  std::set<std::string> required;
  for (const json& e : arrayOf(doc, "extensionsRequired"))
    if (e.is_string()) required.insert(e.get<std::string>());
  for (const std::string& e : required) {
    auto c = kCompressed.find(e);
    if (c != kCompressed.end()) return makeError(c->second + ", which Tally cannot decode (required extension)");
    if (!isImplementedExtension(e))
      return makeError("requires extension " + e + ", which Tally does not implement");
  }
  for (const json& j : arrayOf(doc, "extensionsUsed")) {
    if (!j.is_string()) continue;
    const std::string e = j.get<std::string>();
    if (required.count(e) || isImplementedExtension(e)) continue;
    if (kCompressed.count(e)) {
      notes.push_back(e + ": used but not implemented; the uncompressed fallback data is drawn");
      continue;
    }
    auto it = kIgnored.find(e);
    notes.push_back(e + ": used but not implemented; " +
                    (it != kIgnored.end() ? it->second : std::string("its data is ignored")));
  }
  return notes;
}

// Buffers: each one's declared byteLength, within its data.
Result<Sizes> checkBuffers(const Source& src, const fs::path& folder) {
  Sizes bufferBytes;
  const json& buffers = arrayOf(src.doc, "buffers");
  for (size_t i = 0; i < buffers.size(); ++i) {
    const json& b = buffers[i];
    auto declared = unsignedField(b, "byteLength", kSaturated);
    if (!declared || *declared == kSaturated)
      return makeError("buffer " + std::to_string(i) + ": byteLength missing or not a non-negative integer");
    Result<uint64_t> data = bufferData(src, b, i, folder);
    if (!data) return makeError(data.error());
    if (*declared > *data)
      return makeError("buffer " + std::to_string(i) + ": byteLength " + std::to_string(*declared) +
                       " exceeds the " + std::to_string(*data) + " bytes of its data");
    bufferBytes.push_back(*declared);
  }
  return bufferBytes;
}

struct View {
  uint64_t length = 0, stride = 0;
};

// Buffer views: within their buffer, with a stride glTF allows.
Result<std::vector<View>> checkBufferViews(const json& doc, const Sizes& bufferBytes) {
  std::vector<View> views;
  for (size_t i = 0; i < arrayOf(doc, "bufferViews").size(); ++i) {
    const json& v = arrayOf(doc, "bufferViews")[i];
    const std::string what = "bufferView " + std::to_string(i);
    auto buffer = unsignedField(v, "buffer", kSaturated);
    if (!buffer || *buffer >= bufferBytes.size()) return makeError(what + ": buffer missing or out of range");
    auto offset = unsignedField(v, "byteOffset", 0), length = unsignedField(v, "byteLength", kSaturated);
    auto stride = unsignedField(v, "byteStride", 0);
    if (!offset || !length || *length == kSaturated || !stride)
      return makeError(what + ": byteOffset, byteLength or byteStride is not a non-negative integer");
    if (addSat(*offset, *length) > bufferBytes[*buffer])
      return makeError(what + ": bytes " + std::to_string(*offset) + " + " + std::to_string(*length) +
                       " run past the end of buffer " + std::to_string(*buffer) + " (" +
                       std::to_string(bufferBytes[*buffer]) + " bytes)");
    if (*stride != 0 && (*stride < 4 || *stride > 252 || *stride % 4 != 0))
      return makeError(what + ": byteStride " + std::to_string(*stride) + " (glTF allows 4 to 252, a multiple of 4)");
    views.push_back({*length, *stride});
  }
  return views;
}

// Accessors: element size, stride and count within their view. The counts,
// one per accessor.
Result<Sizes> checkAccessors(const json& doc, const std::vector<View>& views) {
  Sizes accessorCounts;
  for (size_t i = 0; i < arrayOf(doc, "accessors").size(); ++i) {
    const json& a = arrayOf(doc, "accessors")[i];
    const std::string what = "accessor " + std::to_string(i);
    auto count = unsignedField(a, "count", kSaturated);
    if (!count || *count == kSaturated) return makeError(what + ": count missing or not a non-negative integer");
    const int64_t componentType = intField(a, "componentType", 0);
    const int bytes =
        componentType < INT32_MIN || componentType > INT32_MAX ? 0 : componentBytes(int(componentType));
    const int components = componentsOf(stringField(a, "type"));
    if (bytes == 0)
      return makeError(what + ": componentType " + fieldOrNull(a, "componentType").dump() +
                       " is not a glTF type");
    if (components == 0)
      return makeError(what + ": type " + fieldOrNull(a, "type").dump() + " is not a glTF type");
    accessorCounts.push_back(*count);
    if (!a.contains("bufferView")) continue;  // zeros (or sparse, or compressed: the loader says)
    auto view = unsignedField(a, "bufferView", kSaturated);
    if (!view || *view >= views.size()) return makeError(what + ": bufferView out of range");
    const uint64_t element = uint64_t(bytes) * uint64_t(components);
    const uint64_t stride = views[*view].stride ? views[*view].stride : element;
    if (stride < element)
      return makeError(what + ": byteStride " + std::to_string(stride) + " of bufferView " + std::to_string(*view) +
                       " is smaller than its element (" + std::to_string(element) + " bytes)");
    auto offset = unsignedField(a, "byteOffset", 0);
    if (!offset) return makeError(what + ": byteOffset is not a non-negative integer");
    const uint64_t end = *count == 0 ? *offset : addSat(addSat(*offset, mulSat(stride, *count - 1)), element);
    if (end > views[*view].length)
      return makeError(what + ": reads past the end of bufferView " + std::to_string(*view) + ": " + std::to_string(*count) + " elements of " + std::to_string(element) +
                       " bytes at stride " + std::to_string(stride) + (end == kSaturated ? " overflow 64 bits" : " need " + std::to_string(end) + " bytes") +
                       ", the view has " + std::to_string(views[*view].length));
  }
  return accessorCounts;
}

// A primitive compressed with an extension whose data Tally cannot decode:
// no POSITION, or a POSITION accessor without a bufferView.
std::optional<Error> compressedPrimitive(const json& doc, const json& prim, const std::string& what) {
  if (!prim.contains("extensions") || !prim["extensions"].is_object()) return std::nullopt;
  for (const auto& [name, ext] : prim["extensions"].items()) {
    auto c = kCompressed.find(name);
    if (c != kCompressed.end() && !objectField(prim, "attributes").contains("POSITION"))
      return makeError(what + ": " + c->second + ", which Tally cannot decode");
    if (c != kCompressed.end()) {
      const json& position = prim["attributes"]["POSITION"];
      if (position.is_number_unsigned() && position.get<uint64_t>() < arrayOf(doc, "accessors").size() &&
          !arrayOf(doc, "accessors")[position.get<size_t>()].contains("bufferView"))
        return makeError(what + ": " + c->second + ", which Tally cannot decode");
    }
  }
  return std::nullopt;
}

// Meshes: what one instance draws.
Result<std::vector<MeshCost>> meshCostsOf(const json& doc, const Sizes& accessorCounts) {
  std::vector<MeshCost> meshCosts;
  for (size_t m = 0; m < arrayOf(doc, "meshes").size(); ++m) {
    const json& mesh = arrayOf(doc, "meshes")[m];
    MeshCost cost;
    const json prims = mesh.contains("primitives") && mesh["primitives"].is_array() ? mesh["primitives"] : json::array();
    for (size_t p = 0; p < prims.size(); ++p) {
      const json& prim = prims[p];
      const std::string what = "mesh " + std::to_string(m) + " primitive " + std::to_string(p);
      if (auto e = compressedPrimitive(doc, prim, what)) return *e;
      const json attributes = objectField(prim, "attributes");
      uint64_t vertices = 0;
      if (attributes.contains("POSITION") && attributes["POSITION"].is_number_unsigned() &&
          attributes["POSITION"].get<uint64_t>() < accessorCounts.size())
        vertices = accessorCounts[attributes["POSITION"].get<size_t>()];
      uint64_t elements = vertices;
      if (prim.contains("indices") && prim["indices"].is_number_unsigned() &&
          prim["indices"].get<uint64_t>() < accessorCounts.size())
        elements = accessorCounts[prim["indices"].get<size_t>()];
      const int64_t mode = intField(prim, "mode", 4);
      const uint64_t triangles = mode == 4 ? elements / 3 : (mode == 5 || mode == 6) && elements >= 3 ? elements - 2 : 0;
      cost.primitives += 1;
      cost.triangles = addSat(cost.triangles, triangles);
      cost.vertices = addSat(cost.vertices, vertices);
    }
    meshCosts.push_back(cost);
  }
  return meshCosts;
}

// The node graph: cycles, and what each node instances (memoised, saturating)
// against Tally's limits; then what the default scene instances.
std::optional<Error> checkNodeGraph(const json& doc, const std::vector<MeshCost>& meshCosts) {
  const json& nodes = arrayOf(doc, "nodes");
  std::vector<MeshCost> nodeCost(nodes.size());
  std::vector<int> state(nodes.size(), 0);  // 0 unvisited, 1 on the stack, 2 done
  std::function<std::optional<Error>(size_t)> visit = [&](size_t n) -> std::optional<Error> {
    if (state[n] == 2) return std::nullopt;
    if (state[n] == 1) return makeError("node " + std::to_string(n) + ": the node graph has a cycle through it");
    state[n] = 1;
    const json& node = nodes[n];
    MeshCost c;
    if (node.contains("mesh")) {
      auto mesh = unsignedField(node, "mesh", kSaturated);
      if (!mesh || *mesh >= meshCosts.size()) return makeError("node " + std::to_string(n) + ": mesh out of range");
      c = meshCosts[*mesh];
    }
    if (node.contains("children")) {
      if (!node["children"].is_array()) return makeError("node " + std::to_string(n) + ": children is not an array");
      for (const json& child : node["children"]) {
        if (!child.is_number_unsigned() || child.get<uint64_t>() >= nodes.size())
          return makeError("node " + std::to_string(n) + ": child " + child.dump() + " does not exist");
        const size_t k = child.get<size_t>();
        if (auto e = visit(k)) return e;
        add(c, nodeCost[k]);
      }
    }
    nodeCost[n] = c;
    state[n] = 2;
    // The node where a limit is first crossed names the problem.
    auto over = [&](uint64_t value, uint64_t limit, const char* what) -> std::optional<Error> {
      if (value <= limit) return std::nullopt;
      return makeError("node " + std::to_string(n) + ": instances " +
                       (value == kSaturated ? std::string("more than 2^64") : std::to_string(value)) + " " + what +
                       ", over Tally's limit of " + std::to_string(limit));
    };
    if (auto e = over(c.primitives, kMaxMeshInstances, "mesh primitives (draws)")) return e;
    if (auto e = over(c.triangles, kMaxTriangles, "triangles")) return e;
    if (auto e = over(c.vertices, kMaxVertices, "vertices")) return e;
    return std::nullopt;
  };
  std::vector<size_t> roots;
  const json& scenes = arrayOf(doc, "scenes");
  if (!scenes.empty()) {
    size_t s = doc.contains("scene") && doc["scene"].is_number_unsigned() && doc["scene"].get<size_t>() < scenes.size()
                   ? doc["scene"].get<size_t>()
                   : 0;
    if (scenes[s].contains("nodes") && scenes[s]["nodes"].is_array()) {
      for (const json& r : scenes[s]["nodes"]) {
        if (!r.is_number_unsigned() || r.get<uint64_t>() >= nodes.size())
          return makeError("scene " + std::to_string(s) + ": node " + r.dump() + " does not exist");
        roots.push_back(r.get<size_t>());
      }
    }
  } else {
    for (size_t n = 0; n < nodes.size(); ++n) roots.push_back(n);
  }
  MeshCost total;
  for (size_t r : roots) {
    if (auto e = visit(r)) return *e;
    add(total, nodeCost[r]);
  }
  if (total.primitives > kMaxMeshInstances || total.triangles > kMaxTriangles || total.vertices > kMaxVertices)
    return makeError("the default scene instances " + std::to_string(total.primitives) + " draws, " +
                     std::to_string(total.triangles) + " triangles and " + std::to_string(total.vertices) +
                     " vertices, over Tally's limits of " + std::to_string(kMaxMeshInstances) + ", " +
                     std::to_string(kMaxTriangles) + " and " + std::to_string(kMaxVertices));
  return std::nullopt;
}

}  // namespace

bool isImplementedExtension(const std::string& name) { return kImplemented.count(name) > 0; }

Result<GltfPrecheck> precheckGltf(const std::string& path) {
  Result<Source> read = readSource(path);
  if (!read) return makeError("not a valid glTF file: " + read.error());
  const Source& src = *read;
  const json& doc = src.doc;
  GltfPrecheck out;
  Result<std::vector<std::string>> notes = checkExtensions(doc);
  if (!notes) return makeError(notes.error());
  out.notes = std::move(*notes);
  Result<Sizes> bufferBytes = checkBuffers(src, fs::path(path).parent_path());
  if (!bufferBytes) return makeError(bufferBytes.error());
  Result<std::vector<View>> views = checkBufferViews(doc, *bufferBytes);
  if (!views) return makeError(views.error());
  Result<Sizes> accessorCounts = checkAccessors(doc, *views);
  if (!accessorCounts) return makeError(accessorCounts.error());
  Result<std::vector<MeshCost>> meshCosts = meshCostsOf(doc, *accessorCounts);
  if (!meshCosts) return makeError(meshCosts.error());
  if (auto e = checkNodeGraph(doc, *meshCosts)) return *e;
  return out;
}

}  // namespace tally::scenes

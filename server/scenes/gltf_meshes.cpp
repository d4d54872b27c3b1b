// Geometry: the default scene's node graph walked with its transforms, and
// each triangle primitive instance read, triangulated and transformed into
// one Mesh, with normals and tangents derived where the file has none.
#include "scenes/gltf_loader.hpp"

#include <cmath>
#include <utility>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

namespace tally::scenes::detail {
namespace {

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

}  // namespace

std::string Loader::meshName(int meshIndex, size_t primitive) const {
  const tinygltf::Mesh& m = model.meshes[size_t(meshIndex)];
  std::string name = m.name.empty() ? "mesh " + std::to_string(meshIndex) : m.name;
  if (m.primitives.size() > 1) name += "#" + std::to_string(primitive);
  return name;
}

// The attributes and indices of a triangle primitive, in the order glTF's
// problems are found: the mode, POSITION, the other attributes, the indices,
// COLOR_0.
Result<PrimitiveData> Loader::readPrimitive(int meshIndex, size_t p, const std::string& what) const {
  const tinygltf::Primitive& prim = model.meshes[size_t(meshIndex)].primitives[p];
  auto attribute = [&](const char* name) {
    auto it = prim.attributes.find(name);
    return it == prim.attributes.end() ? -1 : it->second;
  };
  PrimitiveData out;
  // tinygltf leaves an absent mode at -1; glTF's default is triangles.
  const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
      mode != TINYGLTF_MODE_TRIANGLE_FAN) {
    static const char* kModes[] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP"};
    return makeError(what + " primitive " + std::to_string(p) + ": mode " + std::to_string(mode) +
                     (mode >= 0 && mode < 4 ? std::string(" (") + kModes[mode] + ")" : std::string()) +
                     " is not drawn: Tally renders triangles only, and refuses rather than drop them");
  }
  out.mode = mode;
  if (attribute("POSITION") < 0) return makeError(what + ": primitive has no POSITION attribute");
  Result<std::vector<float>> pos = readFloats(model, attribute("POSITION"), 3, false, what + " POSITION");
  if (!pos) return makeError(pos.error());
  const size_t n = pos->size() / 3;
  for (size_t i = 0; i < pos->size(); ++i) {
    if (!std::isfinite((*pos)[i]))
      return makeError(what + " POSITION (accessor " + std::to_string(attribute("POSITION")) + "): vertex " +
                       std::to_string(i / 3) + " is not finite (" + std::to_string((*pos)[i]) + ")");
  }
  out.vertices = n;
  out.positions = std::move(*pos);
  for (auto [name, comps, into, normalized] :
       {std::tuple{"NORMAL", 3, &out.normals, false}, std::tuple{"TEXCOORD_0", 2, &out.uv, true},
        std::tuple{"TANGENT", 4, &out.tangents, false}, std::tuple{"TEXCOORD_1", 2, &out.uv1, true}}) {
    if (attribute(name) < 0) continue;
    Result<std::vector<float>> r = readFloats(model, attribute(name), comps, normalized, what + " " + name);
    if (!r) return makeError(r.error());
    if (r->size() / size_t(comps) != n)
      return makeError(what + ": " + name + " count differs from POSITION count");
    *into = std::move(*r);
  }
  if (prim.indices >= 0) {
    Result<std::vector<uint32_t>> idx = readIndices(model, prim.indices, n, what);
    if (!idx) return makeError(idx.error());
    out.indices = std::move(*idx);
  } else {
    out.indices.resize(n);
    for (uint32_t i = 0; i < n; ++i) out.indices[i] = i;
  }

  if (attribute("COLOR_0") >= 0) {
    const int index = attribute("COLOR_0");
    const int components = size_t(index) < model.accessors.size() && model.accessors[size_t(index)].type == TINYGLTF_TYPE_VEC3 ? 3 : 4;
    Result<std::vector<float>> r = readFloats(model, index, components, true, what + " COLOR_0");
    if (!r) return makeError(r.error());
    if (r->size() / size_t(components) != n) return makeError(what + ": COLOR_0 count differs from POSITION count");
    out.colors.resize(n * 4, 1.0f);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < components; ++c) out.colors[i * 4 + size_t(c)] = (*r)[i * size_t(components) + size_t(c)];
  }
  return out;
}

Result<bool> Loader::addPrimitive(int meshIndex, size_t p, const glm::mat4& transform) {
  const tinygltf::Primitive& prim = model.meshes[size_t(meshIndex)].primitives[p];
  const std::string what = "mesh " + quote(meshName(meshIndex, p));
  Result<PrimitiveData> data = readPrimitive(meshIndex, p, what);
  if (!data) return makeError(data.error());
  const size_t n = data->vertices;
  const std::vector<float>& nrm = data->normals;
  const std::vector<float>& uv = data->uv;
  const std::vector<float>& tan = data->tangents;
  const std::vector<float>& uv1 = data->uv1;
  const std::vector<float>& colors = data->colors;
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
  triangulate(data->mode, data->indices, &mesh.indices);
  const float det = glm::determinant(glm::mat3(transform));
  if (det < 0.0f)  // a mirroring transform flips the winding; restore counter-clockwise fronts
    for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3)
      std::swap(mesh.indices[i + 1], mesh.indices[i + 2]);
  const glm::mat3 normalMatrix = glm::inverseTranspose(glm::mat3(transform));
  const std::vector<float>& pos = data->positions;
  mesh.vertices.resize(n);
  for (size_t i = 0; i < n; ++i) {
    Vertex& v = mesh.vertices[i];
    v.position =
        glm::vec3(transform * glm::vec4(pos.at(3 * i), pos.at(3 * i + 1), pos.at(3 * i + 2), 1.0f));
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

Result<bool> Loader::addNode(int nodeIndex, const glm::mat4& parent, int depth) {
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

Result<bool> Loader::loadNodes() {
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

}  // namespace tally::scenes::detail

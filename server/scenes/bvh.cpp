#include "scenes/bvh.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace tally::scenes {
namespace {

constexpr int kBins = 16;               // SAH bins per axis: within a few % of a full sweep, much cheaper
constexpr uint32_t kLeafSize = 4;       // always a leaf at or below this many triangles
constexpr uint32_t kMaxLeafSize = 16;   // SAH may make leaves up to this size when splitting does not pay
constexpr float kTraversalCost = 1.0f;  // relative to one triangle test
constexpr int kStackSize = 64;          // traversal holds at most depth + 1 nodes
constexpr uint32_t kMaxDepth = kStackSize - 4;  // deeper subtrees become (large) leaves
// Barycentric slack so rays through a shared edge hit one of its triangles
// (a miss there would count as sky).
constexpr float kEdgeEpsilon = 1e-6f;

struct Box {
  glm::vec3 lo{3.0e38f}, hi{-3.0e38f};
  void extend(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void extend(const Box& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  float area() const {
    glm::vec3 d = glm::max(hi - lo, glm::vec3(0.0f));
    return 2.0f * (d.x * d.y + d.y * d.z + d.z * d.x);
  }
};

struct BuildTriangle {
  Box box;
  glm::vec3 centroid;
};

struct Builder {
  const std::vector<BuildTriangle>& tris;
  std::vector<uint32_t>& order;

  struct Split {
    int axis = -1;
    float position = 0.0f;
    float cost = 3.0e38f;
  };

  Split findSplit(uint32_t begin, uint32_t end, const Box& centroids) const {
    Split best;
    for (int axis = 0; axis < 3; ++axis) {
      float lo = centroids.lo[axis], hi = centroids.hi[axis];
      if (!(hi > lo)) continue;
      float scale = float(kBins) / (hi - lo);
      std::array<Box, kBins> boxes;
      std::array<uint32_t, kBins> counts{};
      for (uint32_t i = begin; i < end; ++i) {
        const BuildTriangle& t = tris[order[i]];
        int b = std::min(kBins - 1, int((t.centroid[axis] - lo) * scale));
        counts[b]++;
        boxes[b].extend(t.box);
      }
      // Sweep from the right, then from the left, evaluating each plane.
      std::array<float, kBins> rightArea{};
      std::array<uint32_t, kBins> rightCount{};
      Box acc;
      uint32_t n = 0;
      for (int b = kBins - 1; b > 0; --b) {
        acc.extend(boxes[b]);
        n += counts[b];
        rightArea[b] = acc.area();
        rightCount[b] = n;
      }
      acc = Box{};
      n = 0;
      for (int b = 0; b < kBins - 1; ++b) {
        acc.extend(boxes[b]);
        n += counts[b];
        if (n == 0 || rightCount[b + 1] == 0) continue;
        float cost = acc.area() * float(n) + rightArea[b + 1] * float(rightCount[b + 1]);
        if (cost < best.cost) best = {axis, lo + float(b + 1) / scale, cost};
      }
    }
    return best;
  }
};

}  // namespace

Bvh Bvh::build(const Scene& scene) {
  Bvh bvh;
  std::vector<BuildTriangle> tris;
  tris.reserve(scene.triangleCount());
  bvh.triangles_.reserve(scene.triangleCount());
  for (const Mesh& m : scene.meshes) {
    // As the renderers draw it (renderers/gpu_scene.cpp): the mesh's
    // material, clamped to the last one; double-sided when there is none.
    const bool singleSided =
        !scene.materials.empty() &&
        !scene.materials[std::min<size_t>(m.material, scene.materials.size() - 1)].doubleSided;
    for (size_t i = 0; i + 2 < m.indices.size(); i += 3) {
      const glm::vec3& a = m.vertices[m.indices[i]].position;
      const glm::vec3& b = m.vertices[m.indices[i + 1]].position;
      const glm::vec3& c = m.vertices[m.indices[i + 2]].position;
      BuildTriangle t;
      t.box.extend(a);
      t.box.extend(b);
      t.box.extend(c);
      t.centroid = (a + b + c) / 3.0f;
      tris.push_back(t);
      bvh.triangles_.push_back({a, b - a, c - a, uint32_t(bvh.triangles_.size()), singleSided});
    }
  }
  if (tris.empty()) return bvh;

  std::vector<uint32_t> order(tris.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  Builder builder{tris, order};

  struct Task {
    uint32_t node, begin, end, depth;
  };
  std::vector<Task> tasks;
  bvh.nodes_.reserve(2 * tris.size() / kLeafSize + 1);
  bvh.nodes_.push_back({});
  tasks.push_back({0, 0, uint32_t(tris.size()), 0});
  while (!tasks.empty()) {
    Task task = tasks.back();
    tasks.pop_back();
    Box box, centroids;
    for (uint32_t i = task.begin; i < task.end; ++i) {
      box.extend(tris[order[i]].box);
      centroids.extend(tris[order[i]].centroid);
    }
    const uint32_t count = task.end - task.begin;
    auto makeLeaf = [&] {
      Node& n = bvh.nodes_[task.node];
      n = {box.lo, task.begin, box.hi, count};
    };
    if (count <= kLeafSize || task.depth >= kMaxDepth) {
      makeLeaf();
      continue;
    }
    Builder::Split split = builder.findSplit(task.begin, task.end, centroids);
    // SAH cost relative to the parent's area: traversal + expected triangle tests.
    float splitCost = kTraversalCost + split.cost / std::max(box.area(), 1e-30f);
    uint32_t mid = task.begin;
    if (split.axis >= 0) {
      if (splitCost >= float(count) && count <= kMaxLeafSize) {
        makeLeaf();
        continue;
      }
      mid =
          uint32_t(std::partition(order.begin() + task.begin, order.begin() + task.end,
                                  [&](uint32_t t) { return tris[t].centroid[split.axis] < split.position; }) -
                   order.begin());
    }
    if (mid == task.begin || mid == task.end) {
      // All centroids in one bin (or coincident): split by count along the widest axis.
      glm::vec3 e = centroids.hi - centroids.lo;
      int axis = e.x >= e.y && e.x >= e.z ? 0 : (e.y >= e.z ? 1 : 2);
      mid = task.begin + count / 2;
      std::nth_element(
          order.begin() + task.begin, order.begin() + mid, order.begin() + task.end,
          [&](uint32_t a, uint32_t b) { return tris[a].centroid[axis] < tris[b].centroid[axis]; });
    }
    uint32_t left = uint32_t(bvh.nodes_.size());
    bvh.nodes_.push_back({});
    bvh.nodes_.push_back({});
    bvh.nodes_[task.node] = {box.lo, left, box.hi, 0};
    tasks.push_back({left, task.begin, mid, task.depth + 1});
    tasks.push_back({left + 1, mid, task.end, task.depth + 1});
  }

  std::vector<Triangle> sorted(order.size());
  for (size_t i = 0; i < order.size(); ++i) sorted[i] = bvh.triangles_[order[i]];
  bvh.triangles_ = std::move(sorted);
  return bvh;
}

template <bool kAnyHit>
bool Bvh::traverse(const Ray& ray, Hit* hit) const {
  if (nodes_.empty()) return false;
  glm::vec3 inv;
  for (int i = 0; i < 3; ++i) {
    float d = ray.direction[i];
    // A zero component would give 0 * inf = NaN in the slab test.
    if (std::abs(d) < 1e-30f) d = std::copysign(1e-30f, d);
    inv[i] = 1.0f / d;
  }
  auto slab = [&](const Node& n, float tMax) {
    glm::vec3 t0 = (n.lo - ray.origin) * inv, t1 = (n.hi - ray.origin) * inv;
    glm::vec3 tn = glm::min(t0, t1), tf = glm::max(t0, t1);
    float enter = std::max(std::max(tn.x, tn.y), std::max(tn.z, 0.0f));
    float exit = std::min(std::min(tf.x, tf.y), std::min(tf.z, tMax));
    return enter <= exit ? enter : 3.0e38f;
  };

  float tMax = ray.tMax;
  bool found = false;
  uint32_t stack[kStackSize];
  int top = 0;
  if (slab(nodes_[0], tMax) >= 3.0e38f) return false;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node.count > 0) {
      for (uint32_t i = node.first; i < node.first + node.count; ++i) {
        const Triangle& tri = triangles_[i];
        glm::vec3 p = glm::cross(ray.direction, tri.e2);
        float det = glm::dot(tri.e1, p);
        if (std::abs(det) < 1e-30f) continue;
        float invDet = 1.0f / det;
        glm::vec3 s = ray.origin - tri.v0;
        float u = glm::dot(s, p) * invDet;
        if (u < -kEdgeEpsilon || u > 1.0f + kEdgeEpsilon) continue;
        glm::vec3 q = glm::cross(s, tri.e1);
        float v = glm::dot(ray.direction, q) * invDet;
        if (v < -kEdgeEpsilon || u + v > 1.0f + kEdgeEpsilon) continue;
        float t = glm::dot(tri.e2, q) * invDet;
        if (!(t > 0.0f) || t >= tMax) continue;
        if (ray.cullBackFaces && tri.singleSided && det < 0.0f) continue;  // culled when drawn
        found = true;
        if constexpr (kAnyHit) return true;
        tMax = t;
        // det = dot(e1, d x e2) = -dot(d, e1 x e2): negative when the ray runs
        // along the counter-clockwise side's normal, i.e. sees the back.
        *hit = {t, tri.id, det < 0.0f};
      }
      continue;
    }
    uint32_t l = node.first, r = node.first + 1;
    float tl = slab(nodes_[l], tMax), tr = slab(nodes_[r], tMax);
    if (tl > tr) {
      std::swap(l, r);
      std::swap(tl, tr);
    }
    // Near child popped first.
    if (tr < 3.0e38f) stack[top++] = r;
    if (tl < 3.0e38f) stack[top++] = l;
  }
  return found;
}

bool Bvh::anyHit(const Ray& ray) const { return traverse<true>(ray, nullptr); }

std::optional<Hit> Bvh::closestHit(const Ray& ray) const {
  Hit hit;
  if (!traverse<false>(ray, &hit)) return std::nullopt;
  return hit;
}

}  // namespace tally::scenes

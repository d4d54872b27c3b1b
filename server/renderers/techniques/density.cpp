#include "renderers/techniques/density.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace tally::renderers::density {
namespace {

// Sums the R32_SFLOAT texels: total, texels above 0.
std::pair<uint64_t, uint64_t> sumTexels(const std::vector<uint8_t>& bytes) {
  uint64_t total = 0, nonZero = 0;
  for (size_t i = 0; i + sizeof(float) <= bytes.size(); i += sizeof(float)) {
    float v;
    std::memcpy(&v, bytes.data() + i, sizeof v);
    if (v > 0) {
      total += uint64_t(std::llround(v));
      ++nonZero;
    }
  }
  return {total, nonZero};
}

double ratio(uint64_t a, uint64_t b) { return b ? double(a) / double(b) : 0.0; }

}  // namespace

double screenArea(const glm::dvec2& p0, const glm::dvec2& p1, const glm::dvec2& p2) {
  const glm::dvec2 e0 = p1 - p0, e2 = p0 - p2;
  return 0.5 * std::abs(e0.x * e2.y - e0.y * e2.x);
}

TriangleClass classify(const glm::dvec2& p0, const glm::dvec2& p1, const glm::dvec2& p2) {
  const double area = screenArea(p0, p1, p2);
  if (area < kSubPixelArea) return TriangleClass::SubPixel;
  const glm::dvec2 e0 = p1 - p0, e1 = p2 - p1, e2 = p0 - p2;
  const double longest = std::sqrt(std::max({glm::dot(e0, e0), glm::dot(e1, e1), glm::dot(e2, e2)}));
  return 2.0 * area / longest < kThinAltitude ? TriangleClass::LongThin : TriangleClass::Normal;
}

Census census(const GpuScene& scene, const glm::mat4& viewProj, VkExtent2D extent) {
  Census c;
  const auto& positions = scene.cpuPositions();
  const auto& indices = scene.cpuIndices();
  const glm::dmat4 m(viewProj);
  const int W = int(extent.width), H = int(extent.height);
  std::vector<uint8_t> covered(size_t(W) * size_t(H), 0);
  for (const auto& d : scene.draws()) {
    for (uint32_t t = 0; t + 2 < d.indexCount; t += 3) {
      ++c.submitted;
      glm::dvec4 clip[3];
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = uint32_t(int64_t(indices[d.firstIndex + t + uint32_t(k)]) + d.vertexOffset);
        clip[k] = m * glm::dvec4(glm::dvec3(positions[v]), 1.0);
      }
      auto allOutside = [&](auto outside) { return outside(clip[0]) && outside(clip[1]) && outside(clip[2]); };
      if (allOutside([](const glm::dvec4& p) { return p.x < -p.w; }) ||
          allOutside([](const glm::dvec4& p) { return p.x > p.w; }) ||
          allOutside([](const glm::dvec4& p) { return p.y < -p.w; }) ||
          allOutside([](const glm::dvec4& p) { return p.y > p.w; }) ||
          allOutside([](const glm::dvec4& p) { return p.z < 0; }) ||
          allOutside([](const glm::dvec4& p) { return p.z > p.w; })) {
        continue;
      }
      // The homogeneous 2D edge functions (Olano and Greer): a pixel centre
      // is inside when all three share det's sign; this holds for triangles
      // crossing w = 0 too (the part in front of the eye).
      const glm::dmat3 M(glm::dvec3(clip[0].x, clip[0].y, clip[0].w), glm::dvec3(clip[1].x, clip[1].y, clip[1].w),
                         glm::dvec3(clip[2].x, clip[2].y, clip[2].w));
      const double det = glm::determinant(M);
      if (det == 0.0) continue;  // zero area: nothing to rasterise
      const bool nearClipped = clip[0].z < 0 || clip[1].z < 0 || clip[2].z < 0;
      const bool behind = clip[0].w <= 0 || clip[1].w <= 0 || clip[2].w <= 0;
      glm::dvec2 p[3];
      for (int k = 0; k < 3; ++k) {
        p[k] = behind ? glm::dvec2(0) : (glm::dvec2(clip[k]) / clip[k].w * 0.5 + 0.5) * glm::dvec2(W, H);
      }
      ++c.inView;
      // NDC and pixels are y down: the scene's counter-clockwise front faces
      // turn clockwise there, a negative determinant (its sign is the
      // orientation whatever the signs of w).
      if (det < 0) ++c.frontFacing;
      if (nearClipped) {
        ++c.clippedNear;
        ++c.normal;
      } else {
        switch (classify(p[0], p[1], p[2])) {
          case TriangleClass::SubPixel: ++c.subPixel; break;
          case TriangleClass::LongThin: ++c.longThin; break;
          case TriangleClass::Normal: ++c.normal; break;
        }
        const double area = screenArea(p[0], p[1], p[2]);
        const int bucket = area > 0 ? std::clamp(int(std::floor(std::log2(area))), kLowestBucket, kHighestBucket)
                                    : kLowestBucket;
        ++c.log2Area[bucket];
      }
      // Rasterise: the bounding box (the whole screen when a vertex is behind the eye).
      int x0 = 0, y0 = 0, x1 = W - 1, y1 = H - 1;
      if (!behind) {
        x0 = std::max(0, int(std::floor(std::min({p[0].x, p[1].x, p[2].x}))));
        y0 = std::max(0, int(std::floor(std::min({p[0].y, p[1].y, p[2].y}))));
        x1 = std::min(W - 1, int(std::ceil(std::max({p[0].x, p[1].x, p[2].x}))));
        y1 = std::min(H - 1, int(std::ceil(std::max({p[0].y, p[1].y, p[2].y}))));
      }
      if (x0 > x1 || y0 > y1) continue;
      const glm::dmat3 adj = glm::inverse(M) * det;  // rows: the edge functions, up to det's sign
      auto inside = [&](int x, int y) {
        const glm::dvec3 q((x + 0.5) / W * 2.0 - 1.0, (y + 0.5) / H * 2.0 - 1.0, 1.0);
        const glm::dvec3 e = adj * q;
        return det > 0 ? (e.x >= 0 && e.y >= 0 && e.z >= 0) : (e.x <= 0 && e.y <= 0 && e.z <= 0);
      };
      for (int qy = y0 & ~1; qy <= y1; qy += 2) {
        for (int qx = x0 & ~1; qx <= x1; qx += 2) {
          bool any = false;
          for (int k = 0; k < 4; ++k) {
            const int x = qx + (k & 1), y = qy + (k >> 1);
            if (x >= W || y >= H || !inside(x, y)) continue;
            any = true;
            ++c.rasterSamples;
            uint8_t& cov = covered[size_t(y) * size_t(W) + size_t(x)];
            if (!cov) ++c.rasterPixels;
            cov = 1;
          }
          if (any) ++c.rasterQuads;
        }
      }
    }
  }
  return c;
}

nlohmann::json extras(const Census& c, const std::vector<uint8_t>& countTexels, const std::vector<uint8_t>& laneTexels,
                      bool gpuLanes, const std::vector<uint8_t>& image, uint64_t countedFragments, bool instrumented) {
  nlohmann::json histogram = nlohmann::json::array();
  for (const auto& [k, n] : c.log2Area) histogram.push_back({{"log2_area", k}, {"triangles", n}});
  uint64_t sub = 0, thin = 0, normal = 0, other = 0;
  for (size_t i = 0; i + 3 < image.size(); i += 4) {
    const bool r = image[i] > 0, g = image[i + 1] > 0, b = image[i + 2] > 0;
    if (r && !g && !b) {
      ++sub;
    } else if (g && !r && !b) {
      ++thin;
    } else if (b && !r && !g) {
      ++normal;
    } else {
      ++other;
    }
  }
  const auto [fragments, covered] = sumTexels(countTexels);
  const auto [lanes, laneTexelsUsed] = sumTexels(laneTexels);
  (void)laneTexelsUsed;
  nlohmann::json quad;
  if (gpuLanes) {
    quad = {{"source", "gpu_quad_ops"},
            {"lanes", lanes},
            {"helper_lanes", lanes >= fragments ? lanes - fragments : 0},
            {"covered_pixels", covered},
            {"quad_overshading", ratio(lanes, covered)}};
  } else {
    quad = {{"source", "cpu_raster_no_depth"},
            {"lanes", 4 * c.rasterQuads},
            {"helper_lanes", 4 * c.rasterQuads - c.rasterSamples},
            {"covered_pixels", c.rasterPixels},
            {"quad_overshading", ratio(4 * c.rasterQuads, c.rasterPixels)}};
  }
  nlohmann::json out = {
      {"triangles_submitted", c.submitted},
      {"triangles_in_view", c.inView},
      {"triangles_front_facing", c.frontFacing},
      {"triangles_clipped_near", c.clippedNear},
      {"sub_pixel", c.subPixel},
      {"long_thin", c.longThin},
      {"normal", c.normal},
      {"problematic", c.subPixel + c.longThin},
      {"problematic_fraction", ratio(c.subPixel + c.longThin, c.inView)},
      {"area_histogram", histogram},
      {"pixels", {{"sub_pixel", sub}, {"long_thin", thin}, {"normal", normal}, {"other", other}}},
      {"fragments", fragments},
      {"covered_pixels", covered},
      {"overshading", ratio(fragments, covered)},
      {"quad", quad},
      {"cpu_estimate",
       {{"source", "cpu_raster_no_depth"},
        {"samples", c.rasterSamples},
        {"quads", c.rasterQuads},
        {"covered_pixels", c.rasterPixels},
        {"quad_overshading", ratio(4 * c.rasterQuads, c.rasterPixels)}}},
      {"counted_fragments", nullptr},
      {"agrees", nullptr}};
  if (instrumented) {
    out["counted_fragments"] = countedFragments;
    out["agrees"] = fragments == countedFragments;
  }
  return out;
}

}  // namespace tally::renderers::density

// The plane the precision sweep draws (sweeps/precision.hpp describes it) as
// its spec parser, its scene and its measurement all see it: the view, the
// tilted plane in it, the grid of triangles covering it and the uv mapping
// on it. One definition, so that the parser's triangle limit checks the very
// grid the scene builds. Only the sweep's own files include this.
#pragma once

#include <cmath>
#include <string>

#include <glm/glm.hpp>

#include "sweeps/fields.hpp"
#include "sweeps/precision.hpp"

namespace tally::sweeps::precision_plane {

// The view: camera at the origin looking down -Z, square pixels.
struct View {
  uint32_t width = 0, height = 0;
  double tanHalf = 0, aspect = 0;
};

inline View viewOf(const PrecisionSweepSpec& spec) {
  View v;
  v.width = spec.resolution.width;
  v.height = spec.resolution.height;
  v.tanHalf = std::tan(glm::radians(spec.fovDeg) / 2.0);
  v.aspect = double(float(v.width) / float(v.height));  // as the projection gets it
  return v;
}

// The plane z = -d + a x + b y: view depth changes by kPrecisionTilt / 2 of d
// from the centre to each edge (as the depth sweep's).
struct Plane {
  double d = 0, a = 0, b = 0;
};

inline Plane planeAt(const View& v, double distance) {
  return {distance, 0.5 * kPrecisionTilt / (v.tanHalf * v.aspect), 0.5 * kPrecisionTilt / v.tanHalf};
}

// Half-extents of the plane: at the margin it lies nearer than d / (1 - 2
// tilt), and 1.5x the view there covers every pixel.
inline glm::dvec2 planeHalfExtent(const View& v, double distance) {
  const double halfY = distance / (1.0 - 2 * kPrecisionTilt) * v.tanHalf * 1.5;
  return {halfY * v.aspect, halfY};
}

// The grid of `size` cells covering the plane: cell columns [i0, i1), rows [j0, j1).
struct Grid {
  double i0 = 0, i1 = 0, j0 = 0, j1 = 0;
  double triangles() const { return 2.0 * (i1 - i0) * (j1 - j0); }
};

inline Grid gridOf(const View& v, double distance, double size) {
  const glm::dvec2 half = planeHalfExtent(v, distance);
  return {std::floor(-half.x / size), std::ceil(half.x / size), std::floor(-half.y / size),
          std::ceil(half.y / size)};
}

inline Error tooManyTriangles(const std::string& field, double size, double distance, double triangles) {
  return fields::fieldError(field, "legs of " + fields::num(size) + " m tile the plane at distance " +
                                       fields::num(distance) + " with " + fields::num(triangles) +
                                       " triangles, more than the limit of " +
                                       std::to_string(kMaxPrecisionTriangles));
}

// uv of world (x, y): scale R(rotation) (x, -y).
struct UvMap {
  double scale = 0, c = 1, s = 0;
  glm::dvec2 operator()(glm::dvec2 p) const {
    const double x = p.x, y = -p.y;
    return scale * glm::dvec2(c * x - s * y, s * x + c * y);
  }
};

inline UvMap uvMapOf(const PrecisionSweepSpec& spec) {
  const double r = glm::radians(spec.uvRotationDeg);
  return {spec.texelsPerMetre / double(spec.textureSize), std::cos(r), std::sin(r)};
}

}  // namespace tally::sweeps::precision_plane

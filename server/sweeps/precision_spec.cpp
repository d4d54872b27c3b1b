#include "sweeps/precision.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include "sweeps/fields.hpp"
#include "sweeps/precision_plane.hpp"

namespace tally::sweeps {
namespace {

using fields::fieldError;
using fields::num;
using fields::show;
using nlohmann::json;
using precision_plane::gridOf;
using precision_plane::tooManyTriangles;
using precision_plane::View;
using precision_plane::viewOf;
using renderers::BarycentricEncoding;
using renderers::UvDerivativeEncoding;

// An axis of distinct positive finite numbers (metres).
Result<std::vector<double>> positiveList(const json& j, const std::string& field) {
  return fields::distinctList<double>(
      j, field, kMaxPrecisionAxis, "numbers", [](const json& v, const std::string& f) -> Result<double> {
        if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() <= 0 ||
            v.get<double>() > 1e6) {
          return fieldError(f, "must be a number in (0, 1e6] metres, got " + show(v));
        }
        return v.get<double>();
      });
}

// A finite number in [lo, hi] (or (lo, hi] when `openLow`).
Result<double> numberIn(const json& j, const std::string& field, double lo, double hi, bool openLow) {
  if (!j.is_number() || !std::isfinite(j.get<double>()) || j.get<double>() > hi ||
      (openLow ? j.get<double>() <= lo : j.get<double>() < lo)) {
    return fieldError(field, "must be a number in " + std::string(openLow ? "(" : "[") + num(lo) + ", " +
                                 num(hi) + "], got " + show(j));
  }
  return j.get<double>();
}

}  // namespace

uint32_t PrecisionSweepSpec::levels() const { return uint32_t(std::countr_zero(textureSize)) + 1; }

Result<PrecisionSweepSpec> parsePrecisionSweepSpec(const json& j) {
  if (auto e =
          fields::specObject(j, {"sweep", "distances", "triangle_sizes", "texture_size", "texels_per_metre",
                                 "uv_rotation_deg", "resolution", "fov_deg", "threshold"}))
    return *e;
  PrecisionSweepSpec spec;
  spec.source = j;

  if (!j.contains("distances")) return fieldError("distances", "required, e.g. [2, 8, 32]");
  auto distances = positiveList(j["distances"], "distances");
  if (!distances) return distances.failure();
  spec.distances = *distances;
  if (!j.contains("triangle_sizes")) return fieldError("triangle_sizes", "required, e.g. [0.25, 1, 4]");
  auto sizes = positiveList(j["triangle_sizes"], "triangle_sizes");
  if (!sizes) return sizes.failure();
  spec.triangleSizes = *sizes;

  if (j.contains("texture_size")) {
    const auto& t = j["texture_size"];
    const bool integer = t.is_number_integer() && t.get<int64_t>() >= kMinPrecisionTexture &&
                         t.get<int64_t>() <= kMaxPrecisionTexture;
    if (!integer || !std::has_single_bit(uint64_t(t.get<int64_t>()))) {
      return fieldError("texture_size", "must be a power of two from " +
                                            std::to_string(kMinPrecisionTexture) + " to " +
                                            std::to_string(kMaxPrecisionTexture) + ", got " + show(t));
    }
    spec.textureSize = uint32_t(t.get<int64_t>());
  }
  if (j.contains("texels_per_metre")) {
    auto v = numberIn(j["texels_per_metre"], "texels_per_metre", 0.0, 1e6, true);
    if (!v) return v.failure();
    spec.texelsPerMetre = *v;
  }
  if (j.contains("uv_rotation_deg")) {
    auto v = numberIn(j["uv_rotation_deg"], "uv_rotation_deg", -360.0, 360.0, false);
    if (!v) return v.failure();
    spec.uvRotationDeg = *v;
  }
  if (j.contains("resolution")) {
    auto r = fields::resolution(j["resolution"]);
    if (!r) return r.failure();
    spec.resolution = *r;
  }
  if (j.contains("fov_deg")) {
    auto v = numberIn(j["fov_deg"], "fov_deg", 1.0, 170.0, false);
    if (!v) return v.failure();
    spec.fovDeg = *v;
  }
  if (j.contains("threshold")) {
    const auto& t = j["threshold"];
    if (!t.is_object()) {
      return fieldError("threshold",
                        "must be {\"image_max_abs\": levels, \"mip_level\": levels}, got " + show(t));
    }
    if (auto e = json_fields::unknownKey(t, "threshold", {"image_max_abs", "mip_level"})) return *e;
    if (t.contains("image_max_abs")) {
      auto v = numberIn(t["image_max_abs"], "threshold.image_max_abs", 0.0, 255.0, true);
      if (!v) return v.failure();
      spec.imageThreshold = *v;
    }
    if (t.contains("mip_level")) {
      auto v = numberIn(t["mip_level"], "threshold.mip_level", 0.0, 16.0, true);
      if (!v) return v.failure();
      spec.mipThreshold = *v;
    }
  }

  const size_t renders = spec.distances.size() * spec.triangleSizes.size() * (precisionVariants().size() + 1);
  if (renders > kMaxPrecisionRenders) {
    return fieldError("spec", "distances x triangle_sizes x " +
                                  std::to_string(precisionVariants().size() + 1) + " encodings is " +
                                  std::to_string(renders) + " renders, more than the limit of " +
                                  std::to_string(kMaxPrecisionRenders));
  }
  // Every (distance, size) must tessellate within the triangle limit; the
  // grid's size does not depend on the texture, so checking costs nothing.
  const View view = viewOf(spec);
  for (double distance : spec.distances) {
    for (size_t k = 0; k < spec.triangleSizes.size(); ++k) {
      const double triangles = gridOf(view, distance, spec.triangleSizes[k]).triangles();
      if (triangles > double(kMaxPrecisionTriangles)) {
        return tooManyTriangles("triangle_sizes[" + std::to_string(k) + "]", spec.triangleSizes[k], distance,
                                triangles);
      }
    }
  }
  return spec;
}

PrecisionVariant precisionReference() {
  return {"reference", {BarycentricEncoding::Float32, UvDerivativeEncoding::Float32}};
}

std::vector<PrecisionVariant> precisionVariants() {
  return {precisionReference(),
          {"unorm16-barycentrics", {BarycentricEncoding::Unorm16, UvDerivativeEncoding::Float32}},
          {"half-derivatives", {BarycentricEncoding::Float32, UvDerivativeEncoding::Half}},
          {"study-derivatives", {BarycentricEncoding::Float32, UvDerivativeEncoding::Unorm16Clamped}},
          {"tally", {BarycentricEncoding::Unorm16, UvDerivativeEncoding::Half}},
          {"study", {BarycentricEncoding::Unorm16, UvDerivativeEncoding::Unorm16Clamped}}};
}

}  // namespace tally::sweeps

#include "sweeps/edges.hpp"

#include <algorithm>
#include <cmath>

#include "sweeps/depth.hpp"  // kMaxSweepAxis
#include "sweeps/fields.hpp"

namespace tally::sweeps {

using fields::fieldError;
using fields::show;
using nlohmann::json;

std::vector<std::string> edgeRenderers() { return {"visbuffer", "visbuffer-lean"}; }

Result<EdgesSweepSpec> parseEdgesSweepSpec(const json& j, const std::vector<std::string>& knownRenderers) {
  if (auto e = fields::specObject(j, {"sweep", "renderer", "selections", "cell_sizes", "materials",
                                      "resolution", "same_texture", "threshold"}))
    return *e;
  EdgesSweepSpec spec;
  spec.source = j;

  if (j.contains("renderer")) {
    auto name = fields::rendererName(j["renderer"], "renderer", edgeRenderers(), knownRenderers,
                                     "binds material maps per draw, not per pixel");
    if (!name) return name.failure();
    spec.renderer = *name;
  }

  if (j.contains("selections")) {
    const auto& s = j["selections"];
    const std::string expected =
        "\"first-lane\", \"uniform\" or \"nonuniform\" (the reference itself, a control)";
    if (!s.is_array() || s.empty() || s.size() > 3) {
      return fieldError("selections", "must be a non-empty array of " + expected + ", got " + show(s));
    }
    for (size_t i = 0; i < s.size(); ++i) {
      std::string f = "selections[" + std::to_string(i) + "]";
      auto parsed =
          s[i].is_string() ? renderers::parseMaterialSelection(s[i].get<std::string>()) : std::nullopt;
      if (!parsed) return fieldError(f, "must be " + expected + ", got " + show(s[i]));
      if (std::find(spec.selections.begin(), spec.selections.end(), *parsed) != spec.selections.end()) {
        return fieldError(f, show(s[i]) + " listed twice");
      }
      spec.selections.push_back(*parsed);
    }
  }

  if (j.contains("materials")) {
    const auto& m = j["materials"];
    if (!m.is_number_integer() || m.get<int64_t>() < 2 || m.get<int64_t>() > kMaxEdgeMaterials) {
      return fieldError("materials", "must be an integer from 2 to " + std::to_string(kMaxEdgeMaterials) +
                                         ", got " + show(m));
    }
    spec.materials = uint32_t(m.get<int64_t>());
  }

  if (j.contains("same_texture")) {
    if (!j["same_texture"].is_boolean()) {
      return fieldError("same_texture", "must be true or false, got " + show(j["same_texture"]));
    }
    spec.sameTexture = j["same_texture"].get<bool>();
  }

  if (j.contains("resolution")) {
    auto r = fields::resolution(j["resolution"]);
    if (!r) return r.failure();
    spec.resolution = *r;
  }

  // Whole pixels: cell edges then fall on pixel edges, half a pixel from every
  // sample point, so the CPU layout and the rasteriser cannot disagree.
  if (!j.contains("cell_sizes")) return fieldError("cell_sizes", "required, e.g. [64, 16, 4, 2, 1]");
  auto cellSizes = fields::distinctList<uint32_t>(
      j["cell_sizes"], "cell_sizes", kMaxSweepAxis, "whole pixel counts",
      [&](const json& c, const std::string& f) -> Result<uint32_t> {
        if (!c.is_number_integer() || c.get<int64_t>() < 1 || c.get<int64_t>() > kMaxEdgeCellSize) {
          return fieldError(f, "must be a whole number of pixels from 1 to " +
                                   std::to_string(kMaxEdgeCellSize) + ", got " + show(c));
        }
        const uint32_t s = uint32_t(c.get<int64_t>());
        const uint64_t cells = (uint64_t{spec.resolution.width + s - 1} / s + 2) *
                               (uint64_t{spec.resolution.height + s - 1} / s + 2);
        if (cells > kMaxEdgeCells) {
          return fieldError(f, "cells of " + std::to_string(s) + " pixels at " +
                                   std::to_string(spec.resolution.width) + "x" +
                                   std::to_string(spec.resolution.height) + " are " + std::to_string(cells) +
                                   " cells, more than the limit of " + std::to_string(kMaxEdgeCells));
        }
        return s;
      });
  if (!cellSizes) return cellSizes.failure();
  spec.cellSizes = *cellSizes;

  if (!j.contains("threshold"))
    return fieldError("threshold", "required, e.g. {\"boundary_error_fraction\": 0.01}");
  const auto& t = j["threshold"];
  if (!t.is_object() || t.size() != 1 || !t.contains("boundary_error_fraction")) {
    return fieldError(
        "threshold",
        "must be {\"boundary_error_fraction\": x} (wrong pixels / covered pixels), got " + show(t));
  }
  const auto& tv = t["boundary_error_fraction"];
  if (!tv.is_number() || !std::isfinite(tv.get<double>()) || tv.get<double>() <= 0 || tv.get<double>() > 1) {
    return fieldError("threshold.boundary_error_fraction", "must be a number in (0, 1], got " + show(tv));
  }
  spec.threshold = tv.get<double>();
  return spec;
}

}  // namespace tally::sweeps

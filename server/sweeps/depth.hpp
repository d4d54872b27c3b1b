// Sweep "depth-reconstruction": how far the position a renderer reconstructs
// from its depth buffer is from the true one, against the near/far ratio and
// the distance. Each point renders one plane facing the camera at a known
// distance with a fixed near/far, reads back the depth the renderer wrote,
// reconstructs every pixel exactly as the renderer's shader does (common.h
// worldFromDepth, with the uniform from renderers/projection.hpp) and compares
// with the analytic ray-plane intersection. Beside it: the float32 depth step
// at that distance mapped back to distance (docs/measurement.md, "Sweep:
// depth reconstruction").
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "sweeps/options.hpp"
#include "common/resolution.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"

namespace tally::sweeps {

inline constexpr std::string_view kDepthSweepName = "depth-reconstruction";
inline constexpr size_t kMaxSweepAxis = 64;     // values per axis (near, far, distances)
inline constexpr size_t kMaxSweepPoints = 512;  // near x far x distances: one render each

struct DepthSweepSpec {
  std::string renderer = "deferred";
  std::vector<double> near;         // metres
  std::vector<double> far;          // metres, when the spec gave "far"
  std::vector<double> farOverNear;  // when the spec gave "far_over_near"
  std::vector<double> distances;    // metres from the eye to the plane, along the view axis
  Resolution resolution = {64, 36};
  double fovDeg = 60.0;             // vertical
  bool relativeThreshold = true;    // else absolute (metres)
  double threshold = 1e-3;
  nlohmann::json source;

  bool byRatio() const { return !farOverNear.empty(); }
  struct Range {
    double near = 0, far = 0;
  };
  // near x (far | far_over_near), in spec order.
  std::vector<Range> ranges() const;
};

// Renderers whose shading pass reconstructs position from depth.
std::vector<std::string> depthReconstructingRenderers();  // "deferred"

Result<DepthSweepSpec> parseDepthSweepSpec(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers);

// The depth perspective() (renderers/projection.hpp) maps view depth t to:
// D(t) = f (t - n) / ((f - n) t), in [0, 1], far = 1.
double depthOf(double t, double zNear, double zFar);
// The spacing of float32 values at D(t), mapped back to distance along a ray
// of length `rayLength` that meets view depth t: ulp(D) * dt/dD * rayLength / t
// with dt/dD = (f - n) t^2 / (f n).
double depthStepDistance(double t, double rayLength, double zNear, double zFar);

Result<nlohmann::json> runDepthSweep(gpu::Context& ctx, const DepthSweepSpec& spec, const SweepOptions& options);

}  // namespace tally::sweeps

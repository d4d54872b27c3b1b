// Bloom's kernel: the discrete Gaussian of an odd width N and the bilinear
// taps that merge its weights in pairs. The renderer bakes both into the blur
// shaders; the tests derive the expected tap counts and responses from them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace tally::renderers {

// sigma = N / 6: the kernel's N taps span +-3 sigma around the centre.
double bloomSigma(uint32_t taps);

// The N discrete weights w[-R..R] (R = (N - 1) / 2), index i holding offset
// i - R, normalised to sum 1 (the truncated Gaussian would lose ~0.3%).
std::vector<double> gaussianWeights(uint32_t taps);

// One linear-filtered tap: `offset` texels from the centre, between the two
// texels whose discrete weights it merges, with their summed weight.
struct LinearTap {
  double offset = 0;
  double weight = 0;
};

// The centre tap, then for each side the pairs (1, 2), (3, 4), ... merged
// into one tap at (a w_a + b w_b) / (w_a + w_b): sampling a linearly
// interpolated signal there returns (w_a s_a + w_b s_b) / (w_a + w_b), so the
// taps reproduce the discrete kernel exactly up to the filter's weight
// precision. An odd R leaves an unpaired outermost texel, a tap of its own.
// Taps: 1 + 2 ceil(R / 2); (N + 1) / 2 where N % 4 == 1 (every allowed width).
std::vector<LinearTap> linearTaps(const std::vector<double>& weights);

// GLSL initialiser of a const float array: "float[3](0.25, 0.5, 0.25)".
std::string glslFloatArray(const std::vector<double>& values);
// A GLSL float literal: "1.0", "0.25".
std::string glslFloat(double value);

}  // namespace tally::renderers

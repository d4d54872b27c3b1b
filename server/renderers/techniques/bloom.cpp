#include "renderers/techniques/bloom.hpp"

#include <cmath>
#include <cstdio>

namespace tally::renderers {

double bloomSigma(uint32_t taps) { return double(taps) / 6.0; }

std::vector<double> gaussianWeights(uint32_t taps) {
  const int radius = int(taps / 2);
  const double sigma = bloomSigma(taps);
  std::vector<double> w;
  double sum = 0;
  for (int i = -radius; i <= radius; ++i) {
    w.push_back(std::exp(-double(i * i) / (2 * sigma * sigma)));
    sum += w.back();
  }
  for (double& x : w) x /= sum;
  return w;
}

std::vector<LinearTap> linearTaps(const std::vector<double>& weights) {
  const int radius = int(weights.size() / 2);
  auto weightAt = [&](int offset) { return weights[size_t(offset + radius)]; };
  std::vector<LinearTap> right;  // offsets > 0; the kernel is symmetric
  for (int a = 1; a <= radius; a += 2) {
    if (a + 1 > radius) {
      right.push_back({double(a), weightAt(a)});
      continue;
    }
    const double wa = weightAt(a), wb = weightAt(a + 1);
    right.push_back({(a * wa + (a + 1) * wb) / (wa + wb), wa + wb});
  }
  std::vector<LinearTap> taps;
  for (auto it = right.rbegin(); it != right.rend(); ++it) taps.push_back({-it->offset, it->weight});
  taps.push_back({0.0, weightAt(0)});
  taps.insert(taps.end(), right.begin(), right.end());
  return taps;
}

std::string glslFloat(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", value);  // float's 24 bits survive the round trip
  std::string v = buf;
  // GLSL needs a float literal: "1" would be an int.
  if (v.find_first_of(".e") == std::string::npos) v += ".0";
  return v;
}

std::string glslFloatArray(const std::vector<double>& values) {
  std::string out = "float[" + std::to_string(values.size()) + "](";
  for (size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + glslFloat(values[i]);
  return out + ")";
}

}  // namespace tally::renderers

#include "analysis/image.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <stb_image_write.h>

namespace tally::analysis {

Result<ImageError> compareImages(std::span<const uint8_t> a, std::span<const uint8_t> b, uint32_t width,
                                 uint32_t height) {
  size_t expected = size_t{width} * height * 4;
  if (a.size() != expected || b.size() != expected) {
    return makeError("images differ in size: " + std::to_string(a.size()) + " and " + std::to_string(b.size()) +
                     " bytes for " + std::to_string(width) + "x" + std::to_string(height) + " RGBA8");
  }
  double squared = 0, absolute = 0;
  int maxAbs = 0;
  for (size_t i = 0; i < expected; i += 4) {
    for (size_t c = 0; c < 3; ++c) {
      int d = std::abs(int{a[i + c]} - int{b[i + c]});
      maxAbs = std::max(maxAbs, d);
      squared += double(d) * d;
      absolute += d;
    }
  }
  double samples = double(width) * height * 3;
  ImageError e;
  e.maxAbs = maxAbs;
  e.meanAbs = absolute / samples;
  double mse = squared / samples;
  e.psnr = mse == 0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(255.0 * 255.0 / mse);
  return e;
}

double psnr(std::span<const uint8_t> a, std::span<const uint8_t> b) {
  if (a.size() != b.size() || a.size() % 4 != 0) return -1;
  auto e = compareImages(a, b, static_cast<uint32_t>(a.size() / 4), 1);
  return e ? e->psnr : -1;
}

std::vector<uint8_t> differenceImage(std::span<const uint8_t> a, std::span<const uint8_t> b, float gain) {
  std::vector<uint8_t> out(std::min(a.size(), b.size()));
  for (size_t i = 0; i < out.size(); ++i) {
    if (i % 4 == 3) {
      out[i] = 255;
      continue;
    }
    float d = std::abs(float(a[i]) - float(b[i])) * gain;
    out[i] = static_cast<uint8_t>(std::min(d, 255.0f));
  }
  return out;
}

std::vector<uint8_t> encodePng(std::span<const uint8_t> rgba, uint32_t width, uint32_t height) {
  std::vector<uint8_t> png;
  auto append = [](void* context, void* data, int size) {
    auto* out = static_cast<std::vector<uint8_t>*>(context);
    auto* bytes = static_cast<const uint8_t*>(data);
    out->insert(out->end(), bytes, bytes + size);
  };
  stbi_write_png_to_func(append, &png, static_cast<int>(width), static_cast<int>(height), 4, rgba.data(),
                         static_cast<int>(width * 4));
  return png;
}

}  // namespace tally::analysis

// Image comparison and PNG encoding for screenshots.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace tally::analysis {

struct ImageError {
  double psnr = 0;     // dB over RGB, 8-bit peak; +infinity when identical
  int maxAbs = 0;      // largest per-channel difference (0..255)
  double meanAbs = 0;  // mean per-channel difference
};

// Compares two RGBA8 images of the same size (alpha ignored).
Result<ImageError> compareImages(std::span<const uint8_t> a, std::span<const uint8_t> b, uint32_t width,
                                 uint32_t height);

// PSNR over RGB of two equally sized RGBA8 images: +infinity when identical,
// -1 when the sizes differ (for tests and quick checks).
double psnr(std::span<const uint8_t> a, std::span<const uint8_t> b);

// |a - b| per channel, scaled by `gain` and clamped: for the A/B/difference viewer.
std::vector<uint8_t> differenceImage(std::span<const uint8_t> a, std::span<const uint8_t> b, float gain = 4.0f);

// PNG bytes of an RGBA8 image (stb_image_write).
std::vector<uint8_t> encodePng(std::span<const uint8_t> rgba, uint32_t width, uint32_t height);

}  // namespace tally::analysis

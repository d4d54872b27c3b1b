// A frame's size in pixels and the limits every capture kind (matrix or sweep)
// checks it against.
#pragma once

#include <cstdint>

namespace tally {

inline constexpr uint32_t kMaxDimension = 16384;          // Vulkan's common maxImageDimension2D
inline constexpr uint64_t kMaxPixels = 7680ull * 4320ull;  // 8K: beyond it a frame's targets pass 1 GiB

struct Resolution {
  uint32_t width = 0;
  uint32_t height = 0;
};

}  // namespace tally

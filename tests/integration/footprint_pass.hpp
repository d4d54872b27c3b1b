// The footprint tests' pass: a small full-screen fragment pass or compute
// dispatch built from a description, its shaders instrumented with
// footprint on, its table filled from the sites, its bitmaps counted per
// line (footprint_test.cpp, footprint_dedup_test.cpp).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "gpu/context.hpp"
#include "spirv/instrument.hpp"

namespace tally::test {

// The tile a block holds for 4-byte texels, written out per block size
// (docs/measurement.md, "Footprint": as square as powers of two allow, wider than tall).
struct TileDims {
  uint32_t w, h;
};
TileDims rgba8Tile(uint32_t blockBytes);
uint64_t rgba8Blocks(uint32_t width, uint32_t height, uint32_t blockBytes);

struct TextureDesc {
  uint32_t size = 64;  // square, RGBA8, full mip chain
  VkFilter filter = VK_FILTER_LINEAR;
  VkSamplerAddressMode address = VK_SAMPLER_ADDRESS_MODE_REPEAT;
};

struct PassDesc {
  bool compute = false;
  std::string source;            // GLSL of the fragment or compute stage
  uint32_t width = 64, height = 64;  // target, or invocations (x, y) of the dispatch (8 x 8 groups)
  std::vector<TextureDesc> textures;       // bindings 0..: sampler2D
  std::vector<VkDeviceSize> buffers;       // then: storage buffers of these sizes
  uint32_t blockBytes = 64;
  bool countArithmetic = false;  // InstrumentOptions::countArithmetic
  bool deriveOnceSites = true;   // InstrumentOptions::deriveOnceSites
  spirv::Mode mode{spirv::CountMode::Accumulate};
  std::optional<spirv::FootprintDedup> dedup;  // InstrumentOptions::footprintDedup
  bool optimize = false;  // the main stage through SPIRV-Tools' performance passes (loops in SSA form)
};

// One line per (binding or "target", read or write).
struct Line {
  uint64_t requestedBytes = 0;
  uint64_t blocks = 0;
};
struct PassResult {
  std::map<std::string, Line> lines;
  std::vector<std::string> notes;
  uint64_t arithmetic = 0;  // the arithmetic slots, summed (countArithmetic)
  size_t derived = 0;       // the modules' derived counts (Instrumented::derived)
  std::vector<spirv::FootprintDedup> dedup;  // what each module's marks skip (Instrumented::footprintDedup)
};

std::string lineKey(const spirv::Site& s);

// Runs one pass described by a PassDesc on the device.
class FootprintPass {
 public:
  explicit FootprintPass(const gpu::Context& ctx) : ctx_(ctx) {}

  Result<PassResult> run(const PassDesc& d);

 private:
  const gpu::Context& ctx_;
  uint32_t counterSet_ = 7;
};

}  // namespace tally::test

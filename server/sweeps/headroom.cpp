#include "sweeps/headroom.hpp"

#include <cmath>

namespace tally::sweeps {

void CounterHeadroom::note(const renderers::FrameResult& frame) {
  for (const auto& pass : frame.passes) {
    if (pass.maxSlotCount > maxSlotCount) {
      maxSlotCount = pass.maxSlotCount;
      maxSlot = pass.name + "/" + pass.maxSlotResource;
    }
  }
}

nlohmann::json toJson(const CounterHeadroom& headroom, spirv::CounterWidth width, uint32_t framesAccumulated) {
  const double held = double(headroom.maxSlotCount) * double(framesAccumulated);
  auto factor = [&](int bits) -> nlohmann::json {
    if (held <= 0) return nullptr;
    return std::ldexp(1.0, bits) / held;
  };
  return {{"width", width == spirv::CounterWidth::Int64 ? "int64" : "uint32_pair"},
          {"frames_accumulated", framesAccumulated},
          {"max_slot_count_per_frame", headroom.maxSlotCount},
          {"max_slot", headroom.maxSlot},
          {"wrap_factor_32bit", factor(32)},
          // uint32_pair carries into its high word: 64 bits, like int64.
          {"wrap_factor", factor(64)}};
}

}  // namespace tally::sweeps

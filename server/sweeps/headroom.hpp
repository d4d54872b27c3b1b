// Counter headroom of a run: the largest count one counter slot reached in
// one frame, and how far that is from wrapping (docs/measurement.md,
// "Counter overflow"). Counters are zeroed every frame, so one frame is what
// accumulates before a readback.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "renderers/renderer.hpp"
#include "spirv/instrument.hpp"

namespace tally::sweeps {

struct CounterHeadroom {
  uint64_t maxSlotCount = 0;  // per frame
  std::string maxSlot;        // "pass/resource"

  // Takes the largest slot of every pass of an instrumented frame.
  void note(const renderers::FrameResult& frame);
};

// {"width", "frames_accumulated", "max_slot_count_per_frame", "max_slot",
//  "wrap_factor_32bit", "wrap_factor"}: a wrap factor is 2^bits / (max slot
// count x frames accumulated), how many times the resolution x overshading
// could grow before a counter of that many bits wraps (null when nothing was
// counted). "wrap_factor" is for the width in use (64 bits for both int64 and
// uint32_pair).
nlohmann::json toJson(const CounterHeadroom& headroom, spirv::CounterWidth width, uint32_t framesAccumulated);

}  // namespace tally::sweeps

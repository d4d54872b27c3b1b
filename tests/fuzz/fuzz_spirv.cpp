// SPIR-V bytes into the instrumentation (spirv::wordsFromBytes,
// spirv::instrument, which validates its input and its output with
// SPIRV-Tools' spirv-val), in every counting mode, with footprint on and off.
// A module that validates must instrument to one that validates too: the
// instrumentation's "internal error" is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>

#include "spirv/instrument.hpp"

namespace {

using namespace tally::spirv;

void check(std::span<const uint32_t> words, const InstrumentOptions& options) {
  auto result = instrument(words, options);
  if (result.ok()) return;
  if (result.error().rfind("internal error", 0) == 0) {
    std::fprintf(stderr, "fuzz_spirv: mode %s, footprint %u: %s\n", toString(options.mode).c_str(),
                 options.footprintBlockBytes, result.error().c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto words = wordsFromBytes(std::span<const uint8_t>(data, size));
  if (!words.ok()) return 0;
  // One configuration per input (spirv-val runs twice per instrumentation,
  // so all of them per input would be seven times slower), picked by a hash
  // of the bytes: over the corpus every counting mode runs, with footprint
  // on and off, counters as 64-bit atomics and as 32-bit pairs, slots per
  // resource and per site.
  static constexpr const char* kModes[] = {
      "exact", "subgroup", "sampled:4", "accumulate", "accumulate:subgroup", "accumulate:lane"};
  uint32_t hash = 2166136261u;  // FNV-1a
  for (size_t i = 0; i < size; ++i) hash = (hash ^ data[i]) * 16777619u;
  InstrumentOptions options;
  options.mode = *parseMode(kModes[hash % 6]);
  options.footprintBlockBytes = (hash >> 8) % 4 == 0 ? 0 : 32u << ((hash >> 8) % 3);
  options.countArithmetic = options.mode.kind == CountMode::Accumulate && (hash >> 12) % 2 == 0;
  if ((hash >> 13) % 2 == 0) options.width = CounterWidth::Uint32Pair;
  options.computeCopies = 1u << ((hash >> 14) % 5);
  options.perSite = (hash >> 17) % 2 == 0;  // slots per site, each site's instruction disassembled
  check(*words, options);
  return 0;
}

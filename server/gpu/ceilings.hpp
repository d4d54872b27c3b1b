// Device ceilings for the roofline (docs/measurement.md, "Device ceilings"):
// the memory bandwidth a streaming copy achieves and the arithmetic rate of
// independent multiply-add chains, each the best of several repetitions
// timed with timestamp queries. Measured once per capture, at its start.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "gpu/context.hpp"

namespace tally::gpu {

struct CeilingOptions {
  // Bytes in each of the copy's two buffers; 0 picks by device type
  // (copyBytesFor). Rounded down to whole 16-byte elements.
  uint64_t copyBytes = 0;
  uint32_t repetitions = 5;  // timed runs of each kernel; the fastest counts
};

struct Ceilings {
  double bandwidthBytesPerS = 0;   // (read + written) / the fastest copy
  double arithmeticOpsPerS = 0;    // 2 per multiply-add per component / the fastest run
  uint64_t copyBytes = 0;          // bytes in each buffer (read once, written once per copy)
  double copySeconds = 0;          // the fastest copy
  uint64_t arithmeticOps = 0;      // operations per arithmetic run
  double arithmeticSeconds = 0;    // the fastest arithmetic run
  uint32_t repetitions = 0;
  std::string timing;              // "timestamps", or "host" where the queue writes none
  uint32_t copyInvocations = 0, fmaInvocations = 0, fmaIterations = 0;
  double measureSeconds = 0;       // host wall time of the whole measurement, set-up included
  uint64_t copyVerifiedBytes = 0;  // destination bytes read back and found equal to the source
};

// The copy size for this device: well past any last-level cache on a GPU
// (256 MiB per buffer on a discrete GPU, 128 MiB on an integrated one) but
// small on a CPU implementation (lavapipe: 64 MiB, past a 32 MiB host L3), where the copy runs on
// the host's cores and must stay fast; at most an eighth of the largest
// device-local heap.
uint64_t copyBytesFor(const Context& ctx);

// Compiles <shaderDir>/ceiling_copy.comp.glsl and ceiling_fma.comp.glsl and
// runs them. Fails with a reason (a shader that does not compile, memory).
Result<Ceilings> measureCeilings(const Context& ctx, const std::string& shaderDir, const CeilingOptions& options = {});

// The result's device.ceilings object (docs/result-schema.md).
nlohmann::json toJson(const Ceilings& ceilings);

}  // namespace tally::gpu

// A static estimate of the arithmetic an invocation of an entry point does,
// for the roofline (docs/measurement.md, "Arithmetic per pass"). Counted from
// the SPIR-V, before any instrumentation:
//   - float arithmetic (OpFAdd, OpFSub, OpFMul, OpFDiv, OpFRem, OpFMod,
//     OpFNegate) and integer arithmetic (OpIAdd, OpISub, OpIMul, OpSDiv,
//     OpUDiv, OpSRem, OpSMod, OpUMod, OpSNegate, shifts, bitwise and/or/xor/
//     not) count one per component of their result;
//   - OpVectorTimesScalar and OpMatrixTimesScalar one per result component;
//     OpDot of n components 2n - 1; OpVectorTimesMatrix, OpMatrixTimesVector
//     and OpMatrixTimesMatrix 2k - 1 per result component (k: the inner
//     dimension); OpOuterProduct one per result component;
//   - GLSL.std.450 calls one per component of the larger of the result and
//     the first operand (length(vec3): 3; normalize(vec3): 3), Fma two.
// Functions count once per call (a helper called twice counts twice); loop
// bodies count once, whatever their trip count; code that never runs (a
// branch not taken) counts as if it did. Conversions, comparisons,
// selections, composites, loads and stores count nothing.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace tally::spirv {

struct Module;

struct ArithmeticCount {
  uint64_t floatOps = 0;
  uint64_t integerOps = 0;
  uint64_t extendedOps = 0;  // GLSL.std.450 calls
  uint64_t total() const { return floatOps + integerOps + extendedOps; }
  bool operator==(const ArithmeticCount&) const = default;
};

struct EntryArithmetic {
  std::string entryPoint;  // OpEntryPoint name
  ArithmeticCount ops;     // per invocation
};

// Operations of each instruction of each function (module order), as the
// estimate counts them; calls count 0 (the callee's instructions count
// where they execute). For counting executed arithmetic per block.
std::vector<std::vector<uint32_t>> arithmeticPerInstruction(const Module& module);

// One count per entry point, in OpEntryPoint order.
std::vector<EntryArithmetic> countArithmetic(const Module& module);
Result<std::vector<EntryArithmetic>> countArithmetic(std::span<const uint32_t> words);

}  // namespace tally::spirv

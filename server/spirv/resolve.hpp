// Resolves the image or pointer operand of an access back to the descriptor
// it reads: set, binding and array index. Follows OpLoad, OpAccessChain,
// OpSampledImage, OpImage, OpCopyObject, OpImageTexelPointer and function
// parameters (through every call site).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "spirv/module.hpp"
#include "spirv/types.hpp"

namespace tally::spirv {

struct Resource {
  enum class Kind { Descriptor, Physical, Unknown };
  Kind kind = Kind::Unknown;
  uint32_t variable = 0;
  int64_t set = -1;
  int64_t binding = -1;
  bool isArray = false;        // the variable is a descriptor array
  bool indexed = false;        // an array index has been applied
  uint32_t arrayLength = 0;    // 0: runtime-sized
  std::optional<uint32_t> constIndex;
  uint32_t dynamicIndex = 0;   // id of the run-time index value
  uint32_t address = 0;        // Physical: the pointer accessed
  bool needsInline = false;    // only inlining can resolve it (see reason)
  std::string reason;          // why Unknown / why inlining is needed

  bool sameAs(const Resource& o) const {
    return kind == o.kind && variable == o.variable && constIndex == o.constIndex &&
           dynamicIndex == o.dynamicIndex && indexed == o.indexed;
  }
};

class Resolver {
 public:
  Resolver(const Module& module, const DefIndex& defs, const Types& types);

  Resource image(uint32_t valueId) const { return image(valueId, 0); }
  Resource pointer(uint32_t pointerId) const { return pointer(pointerId, 0); }
  // The OpVariable a pointer is based on (through access chains), 0 if none.
  uint32_t baseVariable(uint32_t pointerId) const;

 private:
  Resource image(uint32_t valueId, int depth) const;
  Resource pointer(uint32_t pointerId, int depth) const;
  Resource fromVariable(uint32_t variableId) const;
  template <class Fn>
  Resource viaCallers(uint32_t paramId, int depth, Fn&& resolveArg) const;

  const Module& module_;
  const DefIndex& defs_;
  const Types& types_;
  // parameter id -> (function id, parameter position)
  std::unordered_map<uint32_t, std::pair<uint32_t, uint32_t>> params_;
  // function id -> its OpFunctionCall instructions
  std::unordered_map<uint32_t, std::vector<const Instruction*>> callers_;
};

}  // namespace tally::spirv

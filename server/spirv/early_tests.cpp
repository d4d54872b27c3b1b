#include "spirv/early_tests.hpp"

#include <set>
#include <unordered_map>

#include "spirv/types.hpp"

namespace tally::spirv {
namespace {

bool isAtomic(spv::Op op) {
  using O = spv::Op;
  const auto n = static_cast<uint32_t>(op);
  return (n >= static_cast<uint32_t>(O::OpAtomicLoad) && n <= static_cast<uint32_t>(O::OpAtomicXor)) ||
         op == O::OpAtomicFlagTestAndSet || op == O::OpAtomicFlagClear || op == O::OpAtomicFMinEXT ||
         op == O::OpAtomicFMaxEXT || op == O::OpAtomicFAddEXT;
}

// Memory another invocation or the host may see after the draw.
bool sharedMemory(spv::StorageClass storage) {
  using S = spv::StorageClass;
  // Uniform: a store there is to a BufferBlock (uniform blocks are read-only).
  return storage == S::StorageBuffer || storage == S::PhysicalStorageBuffer || storage == S::Uniform ||
         storage == S::Image || storage == S::CrossWorkgroup || storage == S::Generic;
}

std::string storageName(spv::StorageClass storage) {
  using S = spv::StorageClass;
  switch (storage) {
    case S::StorageBuffer: case S::Uniform: return "a storage buffer";
    case S::PhysicalStorageBuffer: return "a buffer device address";
    case S::Image: return "a storage image";
    default: return "memory other invocations see";
  }
}

// Depth, stencil and coverage outputs: with early tests they would be ignored.
std::string outputBlocker(const Module& module, const DefIndex& defs, const Types& types, uint32_t function) {
  auto builtInName = [](uint32_t value) -> const char* {
    switch (static_cast<spv::BuiltIn>(value)) {
      case spv::BuiltIn::FragDepth: return "FragDepth";
      case spv::BuiltIn::FragStencilRefEXT: return "FragStencilRefEXT";
      case spv::BuiltIn::SampleMask: return "SampleMask";
      default: return nullptr;
    }
  };
  for (const auto& ep : module.entryPoints) {
    if (ep.word(2) != function) continue;
    size_t first = 3 + stringWords(ep.literalString(3)).size();
    for (size_t i = first; i < ep.size(); ++i) {
      const Instruction* var = defs.def(ep.word(i));
      if (var == nullptr || var->opcode() != spv::Op::OpVariable) continue;
      if (static_cast<spv::StorageClass>(var->word(3)) != spv::StorageClass::Output) continue;
      auto builtIn = defs.decorationValue(var->resultId(), spv::Decoration::BuiltIn);
      if (builtIn && builtInName(*builtIn) != nullptr) return std::string("it writes ") + builtInName(*builtIn);
      // A built-in may also be a member of an output block.
      const uint32_t pointee = types.pointee(var->resultType());
      const Instruction* block = defs.def(pointee);
      if (block == nullptr || block->opcode() != spv::Op::OpTypeStruct) continue;
      for (uint32_t m = 0; m + 2 < block->size(); ++m) {
        auto member = defs.memberDecorationValue(pointee, m, spv::Decoration::BuiltIn);
        if (member && builtInName(*member) != nullptr) return std::string("it writes ") + builtInName(*member);
      }
    }
  }
  return {};
}

std::string modeBlocker(const Module& module, uint32_t function) {
  using M = spv::ExecutionMode;
  for (const auto& inst : module.executionModes) {
    if (inst.word(1) != function) continue;
    switch (static_cast<M>(inst.word(2))) {
      case M::DepthReplacing: case M::DepthGreater: case M::DepthLess: case M::DepthUnchanged:
        return "it replaces its depth (DepthReplacing)";
      case M::StencilRefReplacingEXT: case M::StencilRefUnchangedFrontAMD: case M::StencilRefGreaterFrontAMD:
      case M::StencilRefLessFrontAMD: case M::StencilRefUnchangedBackAMD: case M::StencilRefGreaterBackAMD:
      case M::StencilRefLessBackAMD:
        return "it replaces its stencil reference";
      case M::EarlyAndLateFragmentTestsAMD: return "it declares EarlyAndLateFragmentTestsAMD";
      default: break;
    }
  }
  return {};
}

// What in one function's body stops early tests, or "".
std::string bodyBlocker(const Function& fn, const Types& types,
                        const std::set<uint32_t>& debugPrintf) {
  using O = spv::Op;
  for (const auto& inst : fn.insts) {
    const O op = inst.opcode();
    if (op == O::OpKill) return "it discards (OpKill)";
    if (op == O::OpTerminateInvocation) return "it discards (OpTerminateInvocation)";
    if (op == O::OpDemoteToHelperInvocation) return "it demotes to a helper invocation (OpDemoteToHelperInvocation)";
    if (op == O::OpImageWrite) return "it writes a storage image (OpImageWrite)";
    if (isAtomic(op)) return "it uses atomics";
    if (op == O::OpExtInst && debugPrintf.count(inst.word(3)) > 0) return "it prints (debugPrintf)";
    if (op == O::OpStore || op == O::OpCopyMemory || op == O::OpCopyMemorySized) {
      auto storage = types.storageClassOfValue(inst.word(1));
      if (storage && sharedMemory(*storage)) return "it stores to " + storageName(*storage);
    }
  }
  return {};
}

}  // namespace

std::string earlyTestsBlocker(const Module& module, const DefIndex& defs, const Types& types, uint32_t function) {
  if (auto why = modeBlocker(module, function); !why.empty()) return why;
  if (auto why = outputBlocker(module, defs, types, function); !why.empty()) return why;
  std::set<uint32_t> debugPrintf;
  for (const auto& inst : module.imports) {
    if (inst.opcode() == spv::Op::OpExtInstImport && inst.literalString(2) == "NonSemantic.DebugPrintf") {
      debugPrintf.insert(inst.resultId());
    }
  }
  std::unordered_map<uint32_t, size_t> byId;
  for (size_t f = 0; f < module.functions.size(); ++f) byId[module.functions[f].id()] = f;
  // Every function the entry point reaches, the entry point first.
  std::set<uint32_t> seen = {function};
  std::vector<uint32_t> work = {function};
  while (!work.empty()) {
    auto it = byId.find(work.back());
    work.pop_back();
    if (it == byId.end()) continue;
    const Function& fn = module.functions[it->second];
    if (auto why = bodyBlocker(fn, types, debugPrintf); !why.empty()) return why;
    for (const auto& inst : fn.insts) {
      if (inst.opcode() == spv::Op::OpFunctionCall && seen.insert(inst.word(3)).second) work.push_back(inst.word(3));
    }
  }
  return {};
}

bool preserveEarlyTests(Module& module, const DefIndex& defs, const Types& types,
                        const std::vector<EntryPoint>& entryPoints, bool add, std::vector<std::string>& notes) {
  bool added = false;
  for (const auto& ep : entryPoints) {
    if (ep.stage != Stage::Fragment) continue;
    bool declared = false;
    for (const auto& inst : module.executionModes) {
      declared |= inst.word(1) == ep.function &&
                  static_cast<spv::ExecutionMode>(inst.word(2)) == spv::ExecutionMode::EarlyFragmentTests;
    }
    if (declared) continue;
    std::string why;
    if (add) {
      why = earlyTestsBlocker(module, defs, types, ep.function);
      if (why.empty()) {
        module.executionModes.emplace_back(
            spv::Op::OpExecutionMode,
            std::vector<uint32_t>{ep.function, static_cast<uint32_t>(spv::ExecutionMode::EarlyFragmentTests)});
        added = true;
        continue;
      }
      why = " and cannot be given them (" + why + ")";
    }
    notes.push_back("fragment entry point '" + ep.name + "' has no early_fragment_tests" + why +
                    ": its counters are side effects, so depth and stencil tests run after it and rejected "
                    "fragments are counted too");
  }
  return added;
}

}  // namespace tally::spirv

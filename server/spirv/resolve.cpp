#include "spirv/resolve.hpp"

namespace tally::spirv {
namespace {
// Deeper chains than this are malformed or adversarial: SPIR-V shaders cannot recurse.
constexpr int kMaxDepth = 64;

Resource unknown(std::string reason) {
  Resource r;
  r.reason = std::move(reason);
  return r;
}
}  // namespace

Resolver::Resolver(const Module& module, const DefIndex& defs, const Types& types)
    : module_(module), defs_(defs), types_(types) {
  for (const auto& f : module_.functions) {
    uint32_t position = 0;
    for (const auto& inst : f.insts) {
      if (inst.opcode() == spv::Op::OpFunctionParameter) params_[inst.resultId()] = {f.id(), position++};
      if (inst.opcode() == spv::Op::OpFunctionCall) callers_[inst.word(3)].push_back(&inst);
    }
  }
}

Resource Resolver::fromVariable(uint32_t variableId) const {
  const Instruction* var = defs_.def(variableId);
  Resource r;
  auto set = defs_.decorationValue(variableId, spv::Decoration::DescriptorSet);
  auto binding = defs_.decorationValue(variableId, spv::Decoration::Binding);
  auto sc = static_cast<spv::StorageClass>(var->word(3));
  if (!set || !binding) {
    return unknown("variable %" + std::to_string(variableId) + " (" + defs_.name(variableId) +
                   ") has no descriptor set/binding (storage class " + std::to_string(static_cast<int>(sc)) + ")");
  }
  r.kind = Resource::Kind::Descriptor;
  r.variable = variableId;
  r.set = *set;
  r.binding = *binding;
  const Instruction* t = defs_.def(types_.pointee(var->resultType()));
  if (t != nullptr && (t->opcode() == spv::Op::OpTypeArray || t->opcode() == spv::Op::OpTypeRuntimeArray)) {
    // An array of descriptors (an array of blocks is too; arrays inside a
    // block are members, reached through a struct first).
    r.isArray = true;
    r.arrayLength = types_.arrayLength(t->resultId()).value_or(0);
  }
  return r;
}

template <class Fn>
Resource Resolver::viaCallers(uint32_t paramId, int depth, Fn&& resolveArg) const {
  auto p = params_.find(paramId);
  if (p == params_.end()) return unknown("parameter %" + std::to_string(paramId) + " not found");
  auto calls = callers_.find(p->second.first);
  if (calls == callers_.end() || calls->second.empty()) {
    return unknown("parameter of function %" + std::to_string(p->second.first) + ", which is never called");
  }
  std::optional<Resource> common;
  for (const Instruction* call : calls->second) {
    uint32_t arg = call->word(4 + p->second.second);
    Resource r = resolveArg(arg, depth + 1);
    if (r.kind == Resource::Kind::Unknown && !r.needsInline) return r;
    // A run-time index computed in the caller is not visible in the callee.
    if (r.dynamicIndex != 0 && defs_.functionOf(r.dynamicIndex) >= 0) {
      r.needsInline = true;
      r.reason = "dynamic descriptor index passed through a function parameter";
    }
    if (!common) {
      common = r;
    } else if (!common->sameAs(r)) {
      common->needsInline = true;
      common->reason = "function %" + std::to_string(p->second.first) + " is called with different resources";
    }
    if (r.needsInline) {
      common->needsInline = true;
      if (common->reason.empty()) common->reason = r.reason;
    }
  }
  return *common;
}

Resource Resolver::image(uint32_t valueId, int depth) const {
  if (depth > kMaxDepth) return unknown("resource chain too deep");
  const Instruction* d = defs_.def(valueId);
  if (d == nullptr) return unknown("undefined id %" + std::to_string(valueId));
  switch (d->opcode()) {
    case spv::Op::OpLoad: return pointer(d->word(3), depth + 1);
    case spv::Op::OpSampledImage:
    case spv::Op::OpImage:
    case spv::Op::OpCopyObject: return image(d->word(3), depth + 1);
    case spv::Op::OpFunctionParameter:
      return viaCallers(valueId, depth, [this](uint32_t arg, int dd) { return image(arg, dd); });
    default:
      return unknown("image comes from opcode " + std::to_string(static_cast<uint32_t>(d->opcode())));
  }
}

Resource Resolver::pointer(uint32_t pointerId, int depth) const {
  if (depth > kMaxDepth) return unknown("resource chain too deep");
  if (types_.storageClassOfValue(pointerId) == spv::StorageClass::PhysicalStorageBuffer) {
    Resource r;
    r.kind = Resource::Kind::Physical;
    if (depth == 0) r.address = pointerId;
    return r;
  }
  const Instruction* d = defs_.def(pointerId);
  if (d == nullptr) return unknown("undefined id %" + std::to_string(pointerId));
  switch (d->opcode()) {
    case spv::Op::OpVariable: return fromVariable(pointerId);
    case spv::Op::OpAccessChain:
    case spv::Op::OpInBoundsAccessChain: {
      Resource r = pointer(d->word(3), depth + 1);
      if (r.kind == Resource::Kind::Descriptor && r.isArray && !r.indexed && d->size() > 4) {
        r.indexed = true;
        uint32_t index = d->word(4);
        if (auto c = types_.constantValue(index)) {
          r.constIndex = static_cast<uint32_t>(*c);
        } else {
          r.dynamicIndex = index;
        }
      }
      return r;
    }
    case spv::Op::OpPtrAccessChain:
    case spv::Op::OpInBoundsPtrAccessChain:
    case spv::Op::OpCopyObject:
    case spv::Op::OpImageTexelPointer: return pointer(d->word(3), depth + 1);
    case spv::Op::OpFunctionParameter:
      return viaCallers(pointerId, depth, [this](uint32_t arg, int dd) { return pointer(arg, dd); });
    default:
      return unknown("pointer comes from opcode " + std::to_string(static_cast<uint32_t>(d->opcode())));
  }
}

uint32_t Resolver::baseVariable(uint32_t pointerId) const {
  for (int depth = 0; depth < kMaxDepth; ++depth) {
    const Instruction* d = defs_.def(pointerId);
    if (d == nullptr) return 0;
    switch (d->opcode()) {
      case spv::Op::OpVariable: return pointerId;
      case spv::Op::OpAccessChain:
      case spv::Op::OpInBoundsAccessChain:
      case spv::Op::OpPtrAccessChain:
      case spv::Op::OpInBoundsPtrAccessChain:
      case spv::Op::OpCopyObject: pointerId = d->word(3); break;
      default: return 0;
    }
  }
  return 0;
}

}  // namespace tally::spirv

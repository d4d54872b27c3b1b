#include "spirv/arith.hpp"

#include <algorithm>
#include <unordered_map>

#include "spirv/module.hpp"

namespace tally::spirv {
namespace {

constexpr uint32_t kGlslFma = 50;  // GLSL.std.450 Fma

enum class Kind { None, Float, Integer };

Kind kindOf(spv::Op op) {
  using spv::Op;
  switch (op) {
    case Op::OpFNegate: case Op::OpFAdd: case Op::OpFSub: case Op::OpFMul: case Op::OpFDiv:
    case Op::OpFRem: case Op::OpFMod: case Op::OpVectorTimesScalar: case Op::OpMatrixTimesScalar:
    case Op::OpVectorTimesMatrix: case Op::OpMatrixTimesVector: case Op::OpMatrixTimesMatrix:
    case Op::OpOuterProduct: case Op::OpDot:
      return Kind::Float;
    case Op::OpSNegate: case Op::OpIAdd: case Op::OpISub: case Op::OpIMul: case Op::OpUDiv:
    case Op::OpSDiv: case Op::OpUMod: case Op::OpSRem: case Op::OpSMod:
    case Op::OpShiftRightLogical: case Op::OpShiftRightArithmetic: case Op::OpShiftLeftLogical:
    case Op::OpBitwiseOr: case Op::OpBitwiseXor: case Op::OpBitwiseAnd: case Op::OpNot:
    case Op::OpIAddCarry: case Op::OpISubBorrow: case Op::OpUMulExtended: case Op::OpSMulExtended:
      return Kind::Integer;
    default:
      return Kind::None;
  }
}

class Counter {
 public:
  explicit Counter(const Module& m) : module_(m) {
    for (const auto& inst : m.imports) {
      if (inst.opcode() == spv::Op::OpExtInstImport && inst.literalString(2) == "GLSL.std.450") glsl_ = inst.resultId();
    }
    auto note = [&](const Instruction& inst) {
      if (inst.hasResult()) {
        defs_[inst.resultId()] = &inst;
        if (inst.hasType()) typeOfValue_[inst.resultId()] = inst.resultType();
      }
    };
    for (const auto& inst : m.globals) note(inst);
    for (size_t f = 0; f < m.functions.size(); ++f) {
      functionIndex_[m.functions[f].id()] = f;
      for (const auto& inst : m.functions[f].insts) note(inst);
    }
  }

  std::vector<std::vector<uint32_t>> perInstruction() const {
    std::vector<std::vector<uint32_t>> out(module_.functions.size());
    for (size_t f = 0; f < module_.functions.size(); ++f) {
      for (const auto& inst : module_.functions[f].insts) {
        ArithmeticCount c;
        add(inst, c);
        out[f].push_back(static_cast<uint32_t>(c.total()));
      }
    }
    return out;
  }

  std::vector<EntryArithmetic> run() {
    std::vector<EntryArithmetic> out;
    for (const auto& ep : module_.entryPoints) {
      EntryArithmetic e;
      e.entryPoint = ep.literalString(3);
      auto f = functionIndex_.find(ep.word(2));
      if (f != functionIndex_.end()) e.ops = function(f->second);
      out.push_back(std::move(e));
    }
    return out;
  }

 private:
  // Components of a type: 1 for scalars, n for vectors, columns x rows for matrices.
  uint64_t components(uint32_t typeId) const {
    auto it = defs_.find(typeId);
    if (it == defs_.end()) return 1;
    const Instruction& t = *it->second;
    if (t.opcode() == spv::Op::OpTypeVector) return t.word(3);
    if (t.opcode() == spv::Op::OpTypeMatrix) return uint64_t{t.word(3)} * components(t.word(2));
    return 1;
  }
  uint64_t valueComponents(uint32_t valueId) const {
    auto it = typeOfValue_.find(valueId);
    return it == typeOfValue_.end() ? 1 : components(it->second);
  }
  // Columns of a matrix type (1 for anything else).
  uint64_t columns(uint32_t typeId) const {
    auto it = defs_.find(typeId);
    return it != defs_.end() && it->second->opcode() == spv::Op::OpTypeMatrix ? it->second->word(3) : 1;
  }
  uint64_t valueColumns(uint32_t valueId) const {
    auto it = typeOfValue_.find(valueId);
    return it == typeOfValue_.end() ? 1 : columns(it->second);
  }

  // Operations of one instruction (0 when it is not arithmetic).
  void add(const Instruction& inst, ArithmeticCount& count) const {
    using spv::Op;
    const Op op = inst.opcode();
    if (op == Op::OpExtInst) {
      if (glsl_ == 0 || inst.word(3) != glsl_) return;
      uint64_t n = components(inst.resultType());
      if (inst.size() > 5) n = std::max(n, valueComponents(inst.word(5)));
      count.extendedOps += inst.word(4) == kGlslFma ? 2 * n : n;
      return;
    }
    const Kind kind = kindOf(op);
    if (kind == Kind::None) return;
    const uint64_t result = components(inst.resultType());
    uint64_t ops = result;
    switch (op) {
      case Op::OpDot: ops = 2 * valueComponents(inst.word(3)) - 1; break;
      case Op::OpMatrixTimesVector: ops = result * (2 * valueColumns(inst.word(3)) - 1); break;
      case Op::OpVectorTimesMatrix: ops = result * (2 * valueComponents(inst.word(3)) - 1); break;
      case Op::OpMatrixTimesMatrix: ops = result * (2 * valueColumns(inst.word(3)) - 1); break;
      case Op::OpIAddCarry: case Op::OpISubBorrow: case Op::OpUMulExtended: case Op::OpSMulExtended:
        ops = valueComponents(inst.word(3));
        break;
      default: break;
    }
    (kind == Kind::Float ? count.floatOps : count.integerOps) += ops;
  }

  // A function's own operations plus, per OpFunctionCall, its callee's.
  ArithmeticCount function(size_t index) {
    if (auto done = memo_.find(index); done != memo_.end()) return done->second;
    if (!active_.emplace(index, true).second) return {};  // recursion (not in shaders): count once
    ArithmeticCount count;
    for (const auto& inst : module_.functions[index].insts) {
      if (inst.opcode() == spv::Op::OpFunctionCall) {
        auto callee = functionIndex_.find(inst.word(3));
        if (callee == functionIndex_.end()) continue;
        ArithmeticCount c = function(callee->second);
        count.floatOps += c.floatOps;
        count.integerOps += c.integerOps;
        count.extendedOps += c.extendedOps;
        continue;
      }
      add(inst, count);
    }
    active_.erase(index);
    memo_[index] = count;
    return count;
  }

  const Module& module_;
  uint32_t glsl_ = 0;
  std::unordered_map<uint32_t, const Instruction*> defs_;
  std::unordered_map<uint32_t, uint32_t> typeOfValue_;
  std::unordered_map<uint32_t, size_t> functionIndex_;
  std::unordered_map<size_t, ArithmeticCount> memo_;
  std::unordered_map<size_t, bool> active_;
};

}  // namespace

std::vector<EntryArithmetic> countArithmetic(const Module& module) { return Counter(module).run(); }

std::vector<std::vector<uint32_t>> arithmeticPerInstruction(const Module& module) {
  return Counter(module).perInstruction();
}

Result<std::vector<EntryArithmetic>> countArithmetic(std::span<const uint32_t> words) {
  auto module = Module::parse(words);
  if (!module) return makeError(module.error());
  return countArithmetic(*module);
}

}  // namespace tally::spirv

// Types, constants, variables, instructions and functions added to the
// module being rewritten, made once each and reused.

#include "spirv/injector.hpp"

#include <algorithm>

namespace tally::spirv {

ModuleBuilder::ModuleBuilder(Module& m, const DefIndex& defs, const Types& types, const InstrumentOptions& options,
                             Instrumented& result)
    : m_(m), defs_(defs), types_(types), options_(options), result_(result), notes_(result.notes) {
  for (const auto& inst : m_.globals) {
    spv::Op op = inst.opcode();
    if (op == spv::Op::OpConstant) {
      std::vector<uint32_t> key = {static_cast<uint32_t>(op), inst.word(1)};
      key.insert(key.end(), inst.words.begin() + 3, inst.words.end());
      constants_.emplace(key, inst.resultId());
    } else if (op >= spv::Op::OpTypeVoid && op <= spv::Op::OpTypeForwardPointer && op != spv::Op::OpTypeStruct &&
               op != spv::Op::OpTypeArray && op != spv::Op::OpTypeRuntimeArray &&
               op != spv::Op::OpTypeForwardPointer) {
      std::vector<uint32_t> key = {static_cast<uint32_t>(op)};
      key.insert(key.end(), inst.words.begin() + 2, inst.words.end());
      types_by_key_.emplace(key, inst.resultId());
    } else if (op == spv::Op::OpVariable) {
      variables_.push_back(inst.resultId());
    }
  }
  vulkanMemoryModel_ = !m_.memoryModel.empty() && m_.memoryModel[0].word(2) == kMemoryModelVulkan;
  for (const auto& f : m_.functions) {
    for (const auto& inst : f.insts) {
      if (inst.opcode() == spv::Op::OpDemoteToHelperInvocation) demotes_ = true;
    }
  }
}

void ModuleBuilder::noteOnce(const std::string& note) {
  if (std::find(notes_.begin(), notes_.end(), note) == notes_.end()) notes_.push_back(note);
}

uint32_t ModuleBuilder::type(spv::Op op, std::vector<uint32_t> operands) {
  std::vector<uint32_t> key = {static_cast<uint32_t>(op)};
  key.insert(key.end(), operands.begin(), operands.end());
  if (auto it = types_by_key_.find(key); it != types_by_key_.end()) return it->second;
  uint32_t id = m_.newId();
  operands.insert(operands.begin(), id);
  newGlobals_.emplace_back(op, std::move(operands));
  types_by_key_.emplace(key, id);
  return id;
}

uint32_t ModuleBuilder::tPtr(spv::StorageClass sc, uint32_t pointee) {
  return type(spv::Op::OpTypePointer, {static_cast<uint32_t>(sc), pointee});
}

uint32_t ModuleBuilder::constant(uint32_t typeId, std::vector<uint32_t> value) {
  std::vector<uint32_t> key = {static_cast<uint32_t>(spv::Op::OpConstant), typeId};
  key.insert(key.end(), value.begin(), value.end());
  if (auto it = constants_.find(key); it != constants_.end()) return it->second;
  uint32_t id = m_.newId();
  std::vector<uint32_t> operands = {typeId, id};
  operands.insert(operands.end(), value.begin(), value.end());
  newGlobals_.emplace_back(spv::Op::OpConstant, std::move(operands));
  constants_.emplace(key, id);
  return id;
}

void ModuleBuilder::addCapability(spv::Capability cap) {
  for (const auto& c : m_.capabilities) {
    if (c.word(1) == static_cast<uint32_t>(cap)) return;
  }
  m_.capabilities.emplace_back(spv::Op::OpCapability, std::vector<uint32_t>{static_cast<uint32_t>(cap)});
}

void ModuleBuilder::addExtension(const std::string& extension) {
  for (const auto& e : m_.extensions) {
    if (e.literalString(1) == extension) return;
  }
  m_.extensions.emplace_back(spv::Op::OpExtension, stringWords(extension));
}

void ModuleBuilder::decorate(uint32_t id, spv::Decoration d, std::vector<uint32_t> extra) {
  std::vector<uint32_t> operands = {id, static_cast<uint32_t>(d)};
  operands.insert(operands.end(), extra.begin(), extra.end());
  newAnnotations_.emplace_back(spv::Op::OpDecorate, std::move(operands));
}

void ModuleBuilder::name(uint32_t id, const std::string& text) {
  std::vector<uint32_t> operands = {id};
  auto w = stringWords(text);
  operands.insert(operands.end(), w.begin(), w.end());
  newNames_.emplace_back(spv::Op::OpName, std::move(operands));
}

// An Input builtin variable of the given type, reusing the module's own.
uint32_t ModuleBuilder::builtin(Stage stage, spv::BuiltIn b, uint32_t valueType, bool anyInt32) {
  uint32_t found = 0;
  for (uint32_t var : variables_) {
    auto value = defs_.decorationValue(var, spv::Decoration::BuiltIn);
    if (!value || *value != static_cast<uint32_t>(b)) continue;
    const Instruction* v = defs_.def(var);
    if (static_cast<spv::StorageClass>(v->word(3)) != spv::StorageClass::Input) continue;
    uint32_t pointee = types_.pointee(v->resultType());
    const Instruction* t = defs_.def(pointee);
    bool int32 = t && t->opcode() == spv::Op::OpTypeInt && t->word(2) == 32;
    if (pointee == valueType || (anyInt32 && int32)) found = var;
  }
  for (auto& [key, var] : createdBuiltins_) {
    if (key == static_cast<uint32_t>(b)) found = var;
  }
  if (found == 0) {
    found = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpVariable,
                             std::vector<uint32_t>{tPtr(spv::StorageClass::Input, valueType), found,
                                                   static_cast<uint32_t>(spv::StorageClass::Input)});
    decorate(found, spv::Decoration::BuiltIn, {static_cast<uint32_t>(b)});
    // A fragment shader's integer inputs are Flat (SubgroupLocalInvocationId).
    if (stage == Stage::Fragment && (valueType == tU32() || valueType == tI32())) {
      decorate(found, spv::Decoration::Flat);
    }
    // Only demotion can turn an invocation into a helper mid-shader; then
    // the read must be volatile. (Mesa 22.3's lavapipe aborts on volatile
    // HelperInvocation loads, so they are not emitted without need.)
    if (b == spv::BuiltIn::HelperInvocation && demotes_ && !vulkanMemoryModel_) {
      decorate(found, spv::Decoration::Volatile);
    }
    createdBuiltins_.emplace_back(static_cast<uint32_t>(b), found);
  }
  stageBuiltins_[stage].insert(found);
  return found;
}

uint32_t ModuleBuilder::op(Body& b, spv::Op o, uint32_t resultType, std::vector<uint32_t> operands) {
  uint32_t id = m_.newId();
  operands.insert(operands.begin(), {resultType, id});
  b.insts.emplace_back(o, std::move(operands));
  return id;
}

void ModuleBuilder::selection(Body& b, uint32_t cond, uint32_t yes, uint32_t no, uint32_t merge) {
  opNoResult(b, spv::Op::OpSelectionMerge, {merge, 0});
  opNoResult(b, spv::Op::OpBranchConditional, {cond, yes, no});
}

uint32_t ModuleBuilder::loadIntAsU32(Body& b, uint32_t var) {
  uint32_t type = types_.pointee(types_.typeOf(var));
  if (type == 0) type = tI32();  // created by us: i32
  const Instruction* t = defs_.def(type);
  bool isSigned = t == nullptr || t->word(3) == 1;
  uint32_t value = op(b, spv::Op::OpLoad, isSigned ? tI32() : tU32(), {var});
  return isSigned ? op(b, spv::Op::OpBitcast, tU32(), {value}) : value;
}

// Where code counted at entry goes: after the entry block's label and its
// OpVariables (and debug lines).
size_t ModuleBuilder::entryStart(const std::vector<Instruction>& insts) {
  size_t at = 0;
  while (at < insts.size() && insts[at].opcode() != spv::Op::OpLabel) ++at;
  ++at;
  while (at < insts.size() && (insts[at].opcode() == spv::Op::OpVariable || insts[at].opcode() == spv::Op::OpLine ||
                               insts[at].opcode() == spv::Op::OpNoLine)) {
    ++at;
  }
  return at;
}

uint32_t ModuleBuilder::glslImport() {
  if (glsl_ != 0) return glsl_;
  for (const auto& inst : m_.imports) {
    if (inst.opcode() == spv::Op::OpExtInstImport && inst.literalString(2) == "GLSL.std.450") glsl_ = inst.resultId();
  }
  if (glsl_ == 0) {
    glsl_ = m_.newId();
    std::vector<uint32_t> operands = {glsl_};
    auto w = stringWords("GLSL.std.450");
    operands.insert(operands.end(), w.begin(), w.end());
    m_.imports.emplace_back(spv::Op::OpExtInstImport, std::move(operands));
  }
  return glsl_;
}

uint32_t ModuleBuilder::ext(Body& b, uint32_t resultType, Glsl inst, std::vector<uint32_t> args) {
  args.insert(args.begin(), {glslImport(), static_cast<uint32_t>(inst)});
  return op(b, spv::Op::OpExtInst, resultType, std::move(args));
}

// A void function of the given parameter types, its first block open.
std::unique_ptr<ModuleBuilder::FnBuild> ModuleBuilder::beginFunction(const std::vector<uint32_t>& paramTypes) {
  auto f = std::make_unique<FnBuild>();
  std::vector<uint32_t> typeOperands = {tVoid()};
  typeOperands.insert(typeOperands.end(), paramTypes.begin(), paramTypes.end());
  uint32_t fnType = type(spv::Op::OpTypeFunction, typeOperands);
  f->id = m_.newId();
  f->fn.insts.emplace_back(spv::Op::OpFunction, std::vector<uint32_t>{tVoid(), f->id, 0, fnType});
  for (uint32_t t : paramTypes) {
    uint32_t p = m_.newId();
    f->fn.insts.emplace_back(spv::Op::OpFunctionParameter, std::vector<uint32_t>{t, p});
    f->params.push_back(p);
  }
  Body b{f->fn.insts};
  label(b, m_.newId());
  return f;
}

uint32_t ModuleBuilder::endFunction(std::unique_ptr<ModuleBuilder::FnBuild> f, const std::string& fnName) {
  Body b{f->fn.insts};
  opNoResult(b, spv::Op::OpReturn, {});
  b.insts.emplace_back(spv::Op::OpFunctionEnd, std::vector<uint32_t>{});
  name(f->id, fnName);
  uint32_t id = f->id;
  newFunctions_.push_back(std::move(f->fn));
  return id;
}

// if (cond) return; the rest of the function continues in a new block.
void ModuleBuilder::returnIf(Body& b, uint32_t cond) {
  uint32_t out = m_.newId(), rest = m_.newId();
  selection(b, cond, out, rest, rest);
  label(b, out);
  opNoResult(b, spv::Op::OpReturn, {});
  label(b, rest);
}

uint32_t ModuleBuilder::fnCall(Body& b, uint32_t fn, std::vector<uint32_t> args) {
  args.insert(args.begin(), fn);
  return op(b, spv::Op::OpFunctionCall, tVoid(), std::move(args));
}

// A u32 (or i32 with `asSigned`) from an integer value of any width and signedness.
uint32_t ModuleBuilder::intAs(Body& b, uint32_t value, bool asSigned) {
  const uint32_t type = types_.typeOf(value);
  if (defs_.def(type) == nullptr) return value;  // created here: a u32 or i32
  return intOfType(b, value, type, asSigned);
}

// intAs for a value whose integer type the caller knows: values made here
// (a component just extracted) are not in the module's definitions.
uint32_t ModuleBuilder::intOfType(Body& b, uint32_t value, uint32_t type, bool asSigned) {
  uint32_t want = asSigned ? tI32() : tU32();
  const Instruction* t = defs_.def(type);
  if (t == nullptr || t->opcode() != spv::Op::OpTypeInt) return value;
  const bool isSigned = t->word(3) == 1;
  if (t->word(2) != 32) value = op(b, isSigned ? spv::Op::OpSConvert : spv::Op::OpUConvert, isSigned ? tI32() : tU32(), {value});
  return isSigned == asSigned ? value : op(b, spv::Op::OpBitcast, want, {value});
}

// Component k of a scalar or vector value (the scalar itself for k = 0).
uint32_t ModuleBuilder::component(Body& b, uint32_t value, uint32_t k, uint32_t scalarType) {
  const Instruction* t = defs_.def(types_.typeOf(value));
  if (t != nullptr && t->opcode() == spv::Op::OpTypeVector) {
    return op(b, spv::Op::OpCompositeExtract, t->word(2), {value, k});
  }
  (void)scalarType;
  return value;
}

// Component k of an integer scalar or vector (coordinates, offsets: signed
// or unsigned, any width) as an i32 (u32 without `asSigned`).
uint32_t ModuleBuilder::intComponent(Body& b, uint32_t value, uint32_t k, bool asSigned) {
  const Instruction* t = defs_.def(types_.typeOf(value));
  if (t == nullptr || t->opcode() != spv::Op::OpTypeVector) return intAs(b, value, asSigned);
  const uint32_t scalar = t->word(2);
  return intOfType(b, op(b, spv::Op::OpCompositeExtract, scalar, {value, k}), scalar, asSigned);
}

uint32_t ModuleBuilder::componentCount(uint32_t value) {
  const Instruction* t = defs_.def(types_.typeOf(value));
  return t != nullptr && t->opcode() == spv::Op::OpTypeVector ? t->word(3) : 1;
}

Instruction ModuleBuilder::call(uint32_t helper, uint32_t slot) {
  return Instruction(spv::Op::OpFunctionCall, {tVoid(), m_.newId(), helper, slot});
}

}  // namespace tally::spirv

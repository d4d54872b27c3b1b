#include "spirv/module.hpp"

#include <optional>

namespace tally::spirv {

std::string versionString(uint32_t version) {
  return std::to_string((version >> 16) & 0xff) + "." + std::to_string((version >> 8) & 0xff);
}

Instruction::Instruction(spv::Op op, std::vector<uint32_t> operands) {
  words.reserve(operands.size() + 1);
  words.push_back((static_cast<uint32_t>(operands.size() + 1) << 16) | static_cast<uint32_t>(op));
  words.insert(words.end(), operands.begin(), operands.end());
}

bool Instruction::hasResult() const {
  bool result = false, type = false;
  spv::HasResultAndType(opcode(), &result, &type);
  return result;
}

bool Instruction::hasType() const {
  bool result = false, type = false;
  spv::HasResultAndType(opcode(), &result, &type);
  return type;
}

uint32_t Instruction::resultId() const {
  if (!hasResult()) return 0;
  return hasType() ? word(2) : word(1);
}

uint32_t Instruction::resultType() const { return hasType() ? word(1) : 0; }

std::string Instruction::literalString(size_t first) const {
  std::string out;
  for (size_t i = first; i < words.size(); ++i) {
    for (int b = 0; b < 4; ++b) {
      char c = static_cast<char>((words[i] >> (8 * b)) & 0xff);
      if (c == '\0') return out;
      out.push_back(c);
    }
  }
  return out;
}

std::vector<uint32_t> stringWords(const std::string& text) {
  std::vector<uint32_t> out((text.size() + 4) / 4, 0u);
  for (size_t i = 0; i < text.size(); ++i) {
    out[i / 4] |= static_cast<uint32_t>(static_cast<uint8_t>(text[i])) << (8 * (i % 4));
  }
  return out;
}

namespace {

enum class Section { Capability, Extension, Import, MemoryModel, EntryPoint, ExecutionMode, Debug,
                     Annotation, Global };

Section sectionOf(spv::Op op) {
  switch (op) {
    case spv::Op::OpCapability: return Section::Capability;
    case spv::Op::OpExtension: return Section::Extension;
    case spv::Op::OpExtInstImport: return Section::Import;
    case spv::Op::OpMemoryModel: return Section::MemoryModel;
    case spv::Op::OpEntryPoint: return Section::EntryPoint;
    case spv::Op::OpExecutionMode:
    case spv::Op::OpExecutionModeId: return Section::ExecutionMode;
    case spv::Op::OpString:
    case spv::Op::OpSourceExtension:
    case spv::Op::OpSource:
    case spv::Op::OpSourceContinued:
    case spv::Op::OpName:
    case spv::Op::OpMemberName:
    case spv::Op::OpModuleProcessed: return Section::Debug;
    case spv::Op::OpDecorate:
    case spv::Op::OpMemberDecorate:
    case spv::Op::OpDecorationGroup:
    case spv::Op::OpGroupDecorate:
    case spv::Op::OpGroupMemberDecorate:
    case spv::Op::OpDecorateId:
    case spv::Op::OpDecorateString:
    case spv::Op::OpMemberDecorateString: return Section::Annotation;
    default: return Section::Global;
  }
}

}  // namespace

Result<Module> Module::parse(std::span<const uint32_t> input) {
  if (input.size() < 5) {
    return makeError("truncated SPIR-V: " + std::to_string(input.size() * 4) +
                     " bytes, a module needs at least a 20-byte header");
  }
  std::vector<uint32_t> words(input.begin(), input.end());
  if (words[0] != kMagic) {
    if (__builtin_bswap32(words[0]) == kMagic) {
      for (auto& w : words) w = __builtin_bswap32(w);
    } else {
      char hex[16];
      std::snprintf(hex, sizeof hex, "0x%08x", words[0]);
      return makeError(std::string("not SPIR-V: wrong magic number ") + hex + " (expected 0x07230203)");
    }
  }
  Module m;
  m.version = words[1];
  if ((m.version & 0xff0000ffu) != 0 || m.version < kVersion10 || m.version > kVersion16) {
    return makeError("unsupported SPIR-V version " + versionString(m.version) + " (supported: 1.0 to 1.6)");
  }
  m.generator = words[2];
  m.bound = words[3];
  m.schema = words[4];
  if (m.bound == 0) return makeError("invalid SPIR-V: id bound is 0");

  Function* current = nullptr;
  bool sawFunction = false;
  size_t at = 5;
  while (at < words.size()) {
    uint32_t count = words[at] >> 16;
    auto op = static_cast<spv::Op>(words[at] & 0xffffu);
    if (count == 0) return makeError("invalid SPIR-V: instruction at word " + std::to_string(at) + " has word count 0");
    if (at + count > words.size()) {
      return makeError("truncated SPIR-V: instruction at word " + std::to_string(at) + " (opcode " +
                       std::to_string(static_cast<uint32_t>(op)) + ") needs " + std::to_string(count) +
                       " words, " + std::to_string(words.size() - at) + " remain");
    }
    Instruction inst;
    inst.words.assign(words.begin() + static_cast<long>(at), words.begin() + static_cast<long>(at + count));
    at += count;

    if (op == spv::Op::OpFunction) {
      if (current != nullptr) return makeError("invalid SPIR-V: OpFunction inside a function");
      m.functions.emplace_back();
      current = &m.functions.back();
      sawFunction = true;
    }
    if (current != nullptr) {
      current->insts.push_back(std::move(inst));
      if (op == spv::Op::OpFunctionEnd) current = nullptr;
      continue;
    }
    if (op == spv::Op::OpFunctionEnd) return makeError("invalid SPIR-V: OpFunctionEnd outside a function");
    if (sawFunction && (op == spv::Op::OpLine || op == spv::Op::OpNoLine)) {
      m.functions.back().insts.push_back(std::move(inst));  // debug lines between functions
      continue;
    }
    if (sawFunction) {
      return makeError("invalid SPIR-V: instruction (opcode " + std::to_string(static_cast<uint32_t>(op)) +
                       ") after the function section");
    }
    switch (sectionOf(op)) {
      case Section::Capability: m.capabilities.push_back(std::move(inst)); break;
      case Section::Extension: m.extensions.push_back(std::move(inst)); break;
      case Section::Import: m.imports.push_back(std::move(inst)); break;
      case Section::MemoryModel: m.memoryModel.push_back(std::move(inst)); break;
      case Section::EntryPoint: m.entryPoints.push_back(std::move(inst)); break;
      case Section::ExecutionMode: m.executionModes.push_back(std::move(inst)); break;
      case Section::Debug: m.debug.push_back(std::move(inst)); break;
      case Section::Annotation: m.annotations.push_back(std::move(inst)); break;
      case Section::Global: m.globals.push_back(std::move(inst)); break;
    }
  }
  if (current != nullptr) return makeError("truncated SPIR-V: function without OpFunctionEnd");
  return m;
}

std::vector<uint32_t> Module::serialize() const {
  std::vector<uint32_t> out = {kMagic, version, generator, bound, schema};
  auto put = [&out](const std::vector<Instruction>& section) {
    for (const auto& inst : section) out.insert(out.end(), inst.words.begin(), inst.words.end());
  };
  put(capabilities);
  put(extensions);
  put(imports);
  put(memoryModel);
  put(entryPoints);
  put(executionModes);
  put(debug);
  put(annotations);
  put(globals);
  for (const auto& f : functions) put(f.insts);
  return out;
}

DefIndex::DefIndex(const Module& module) : module_(module) {
  auto add = [this](const std::vector<Instruction>& section, int function) {
    for (size_t i = 0; i < section.size(); ++i) {
      uint32_t id = section[i].resultId();
      if (id != 0) defs_[id] = Location{function, i, &section};
    }
  };
  add(module.imports, -1);
  add(module.debug, -1);
  add(module.annotations, -1);
  add(module.globals, -1);
  for (size_t f = 0; f < module.functions.size(); ++f) add(module.functions[f].insts, static_cast<int>(f));

  for (const auto& inst : module.annotations) {
    if (inst.opcode() == spv::Op::OpDecorate || inst.opcode() == spv::Op::OpDecorateId ||
        inst.opcode() == spv::Op::OpDecorateString) {
      Decoration d{static_cast<spv::Decoration>(inst.word(2)), {inst.words.begin() + 3, inst.words.end()}};
      decorations_[inst.word(1)].push_back(std::move(d));
    } else if (inst.opcode() == spv::Op::OpMemberDecorate || inst.opcode() == spv::Op::OpMemberDecorateString) {
      Decoration d{static_cast<spv::Decoration>(inst.word(3)), {inst.words.begin() + 4, inst.words.end()}};
      memberDecorations_[(uint64_t{inst.word(1)} << 32) | inst.word(2)].push_back(std::move(d));
    } else if (inst.opcode() == spv::Op::OpGroupDecorate) {
      auto group = decorations_.find(inst.word(1));
      if (group == decorations_.end()) continue;
      auto copy = group->second;
      for (size_t i = 2; i < inst.size(); ++i) {
        auto& list = decorations_[inst.word(i)];
        list.insert(list.end(), copy.begin(), copy.end());
      }
    }
  }
  for (const auto& inst : module.debug) {
    if (inst.opcode() == spv::Op::OpName) names_[inst.word(1)] = inst.literalString(2);
    if (inst.opcode() == spv::Op::OpString) strings_[inst.word(1)] = inst.literalString(2);
  }
}

const Instruction* DefIndex::def(uint32_t id) const {
  auto it = defs_.find(id);
  if (it == defs_.end()) return nullptr;
  return &(*it->second.section)[it->second.index];
}

int DefIndex::functionOf(uint32_t id) const {
  auto it = defs_.find(id);
  return it == defs_.end() ? -1 : it->second.function;
}

const std::vector<DefIndex::Decoration>& DefIndex::decorations(uint32_t id) const {
  static const std::vector<Decoration> kNone;
  auto it = decorations_.find(id);
  return it == decorations_.end() ? kNone : it->second;
}

const std::vector<DefIndex::Decoration>& DefIndex::memberDecorations(uint32_t structId, uint32_t member) const {
  static const std::vector<Decoration> kNone;
  auto it = memberDecorations_.find((uint64_t{structId} << 32) | member);
  return it == memberDecorations_.end() ? kNone : it->second;
}

bool DefIndex::hasDecoration(uint32_t id, spv::Decoration kind) const {
  for (const auto& d : decorations(id)) {
    if (d.kind == kind) return true;
  }
  return false;
}

std::optional<uint32_t> DefIndex::decorationValue(uint32_t id, spv::Decoration kind) const {
  for (const auto& d : decorations(id)) {
    if (d.kind == kind && !d.operands.empty()) return d.operands[0];
  }
  return std::nullopt;
}

std::optional<uint32_t> DefIndex::memberDecorationValue(uint32_t structId, uint32_t member,
                                                        spv::Decoration kind) const {
  for (const auto& d : memberDecorations(structId, member)) {
    if (d.kind == kind && !d.operands.empty()) return d.operands[0];
  }
  return std::nullopt;
}

std::string DefIndex::name(uint32_t id) const {
  auto it = names_.find(id);
  return it == names_.end() ? std::string() : it->second;
}

std::string DefIndex::stringOf(uint32_t id) const {
  auto it = strings_.find(id);
  return it == strings_.end() ? std::string() : it->second;
}

}  // namespace tally::spirv

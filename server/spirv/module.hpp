// A word-level SPIR-V module: parsed into the logical layout sections of the
// SPIR-V spec (2.4), editable by appending to sections, serialized back to
// words. No Vulkan dependency.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#define SPV_ENABLE_UTILITY_CODE
#include <spirv/unified1/spirv.hpp11>

#include "common/result.hpp"

namespace tally::spirv {

constexpr uint32_t kMagic = 0x07230203;
constexpr uint32_t kVersion10 = 0x00010000;
constexpr uint32_t kVersion13 = 0x00010300;
constexpr uint32_t kVersion14 = 0x00010400;
constexpr uint32_t kVersion16 = 0x00010600;

std::string versionString(uint32_t version);  // "1.3"

struct Instruction {
  std::vector<uint32_t> words;  // words[0] = word count << 16 | opcode

  Instruction() = default;
  Instruction(spv::Op op, std::vector<uint32_t> operands);

  spv::Op opcode() const { return static_cast<spv::Op>(words[0] & 0xffffu); }
  size_t size() const { return words.size(); }
  uint32_t word(size_t i) const { return i < words.size() ? words[i] : 0; }
  bool hasResult() const;
  bool hasType() const;
  uint32_t resultId() const;    // 0 if none
  uint32_t resultType() const;  // 0 if none
  // Decodes the nul-terminated literal string starting at word `first`.
  std::string literalString(size_t first) const;
};

// Words of a literal string, nul-terminated and padded.
std::vector<uint32_t> stringWords(const std::string& text);

struct Function {
  std::vector<Instruction> insts;  // OpFunction ... OpFunctionEnd
  uint32_t id() const { return insts.front().resultId(); }
};

struct Module {
  uint32_t version = kVersion10;
  uint32_t generator = 0;
  uint32_t bound = 1;
  uint32_t schema = 0;
  std::vector<Instruction> capabilities, extensions, imports, memoryModel, entryPoints, executionModes,
      debug, annotations, globals;
  std::vector<Function> functions;

  // Checks header and instruction framing, then sorts into sections. Does not
  // check semantics: validate() does that.
  static Result<Module> parse(std::span<const uint32_t> words);
  std::vector<uint32_t> serialize() const;

  uint32_t newId() { return bound++; }
};

// Where each result id is defined, built once after parsing (and rebuilt after
// structural changes). Holds indices, so sections may grow afterwards.
class DefIndex {
 public:
  explicit DefIndex(const Module& module);
  const Instruction* def(uint32_t id) const;
  int functionOf(uint32_t id) const;  // index into module.functions, -1 for globals

  // Decorations: (decoration, extra operands) per target id.
  struct Decoration {
    spv::Decoration kind;
    std::vector<uint32_t> operands;
  };
  const std::vector<Decoration>& decorations(uint32_t id) const;
  const std::vector<Decoration>& memberDecorations(uint32_t structId, uint32_t member) const;
  bool hasDecoration(uint32_t id, spv::Decoration kind) const;
  std::optional<uint32_t> decorationValue(uint32_t id, spv::Decoration kind) const;
  std::optional<uint32_t> memberDecorationValue(uint32_t structId, uint32_t member, spv::Decoration kind) const;
  std::string name(uint32_t id) const;  // OpName, or ""
  std::string stringOf(uint32_t id) const;  // OpString text

 private:
  const Module& module_;
  struct Location {
    int function;  // -1: global sections
    size_t index;
    const std::vector<Instruction>* section;
  };
  std::unordered_map<uint32_t, Location> defs_;
  std::unordered_map<uint32_t, std::vector<Decoration>> decorations_;
  std::unordered_map<uint64_t, std::vector<Decoration>> memberDecorations_;
  std::unordered_map<uint32_t, std::string> names_;
  std::unordered_map<uint32_t, std::string> strings_;
};

}  // namespace tally::spirv

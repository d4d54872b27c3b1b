#include "spirv/site_text.hpp"

#include <sstream>

#include <spirv-tools/libspirv.hpp>

namespace tally::spirv {
namespace {

// spirv-dis --no-header: one line per instruction, in module order.
std::vector<std::string> disassemblyLines(const std::vector<uint32_t>& words) {
  spvtools::SpirvTools tools(SPV_ENV_UNIVERSAL_1_6);
  std::string text;
  if (!tools.Disassemble(words, &text, SPV_BINARY_TO_TEXT_OPTION_NO_HEADER | SPV_BINARY_TO_TEXT_OPTION_FRIENDLY_NAMES)) {
    return {};
  }
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    size_t first = line.find_first_not_of(' ');
    lines.push_back(first == std::string::npos ? std::string() : line.substr(first));
  }
  return lines;
}

// The module with one line of text per instruction: source text (OpSource,
// OpSourceContinued) and strings spanning lines (DebugSource's) would be
// disassembled over several.
Module oneLinePerInstruction(Module module) {
  for (Instruction& inst : module.debug) {
    if (inst.opcode() == spv::Op::OpSource && inst.size() > 4) {
      inst = Instruction(spv::Op::OpSource, {inst.word(1), inst.word(2), inst.word(3)});
    } else if (inst.opcode() == spv::Op::OpSourceContinued) {
      inst = Instruction(spv::Op::OpNop, {});
    } else if (inst.opcode() == spv::Op::OpString) {
      std::string text = inst.literalString(2);
      if (text.find('\n') == std::string::npos && text.find('\r') == std::string::npos) continue;
      for (char& c : text) c = c == '\n' || c == '\r' ? ' ' : c;
      std::vector<uint32_t> operands = {inst.word(1)};
      for (uint32_t w : stringWords(text)) operands.push_back(w);
      inst = Instruction(spv::Op::OpString, std::move(operands));
    }
  }
  return module;
}

}  // namespace

void describeSites(const Module& module, const DefIndex& defs, const std::vector<FoundSite>& found,
                   std::vector<Site>& sites) {
  // Position of each function's first instruction, after the global sections.
  uint32_t at = 0;
  for (const auto* section : {&module.capabilities, &module.extensions, &module.imports, &module.memoryModel,
                              &module.entryPoints, &module.executionModes, &module.debug, &module.annotations,
                              &module.globals}) {
    at += uint32_t(section->size());
  }
  std::vector<uint32_t> functionStart;
  for (const auto& f : module.functions) {
    functionStart.push_back(at);
    at += uint32_t(f.insts.size());
  }
  const std::vector<std::string> lines = disassemblyLines(oneLinePerInstruction(module).serialize());
  for (size_t k = 0; k < found.size() && k < sites.size(); ++k) {
    const FoundSite& f = found[k];
    if (f.shownFunction < 0 || size_t(f.shownFunction) >= module.functions.size()) continue;
    const uint32_t id = module.functions[size_t(f.shownFunction)].id();
    std::string name = defs.name(id);
    sites[k].function = name.empty() ? "%" + std::to_string(id) : name;
    sites[k].instruction = functionStart[size_t(f.shownFunction)] + uint32_t(f.shownInstruction);
    if (sites[k].instruction < lines.size()) sites[k].disassembly = lines[sites[k].instruction];
  }
}

}  // namespace tally::spirv

#include "spirv/types.hpp"

namespace tally::spirv {

uint32_t Types::typeOf(uint32_t valueId) const {
  const Instruction* d = defs_.def(valueId);
  return d == nullptr ? 0 : d->resultType();
}

bool Types::isPointerType(uint32_t typeId) const {
  const Instruction* d = defs_.def(typeId);
  return d != nullptr && (d->opcode() == spv::Op::OpTypePointer || d->opcode() == spv::Op::OpTypeForwardPointer);
}

uint32_t Types::pointee(uint32_t pointerTypeId) const {
  const Instruction* d = defs_.def(pointerTypeId);
  if (d == nullptr || d->opcode() != spv::Op::OpTypePointer) return 0;
  return d->word(3);
}

std::optional<spv::StorageClass> Types::storageClass(uint32_t pointerTypeId) const {
  const Instruction* d = defs_.def(pointerTypeId);
  if (d == nullptr || d->opcode() != spv::Op::OpTypePointer) return std::nullopt;
  return static_cast<spv::StorageClass>(d->word(2));
}

std::optional<spv::StorageClass> Types::storageClassOfValue(uint32_t pointerValueId) const {
  return storageClass(typeOf(pointerValueId));
}

uint32_t Types::byteSize(uint32_t typeId) const {
  const Instruction* t = defs_.def(typeId);
  if (t == nullptr) return 0;
  switch (t->opcode()) {
    case spv::Op::OpTypeInt:
    case spv::Op::OpTypeFloat: return t->word(2) / 8;
    case spv::Op::OpTypeBool: return 4;
    case spv::Op::OpTypeVector: return t->word(3) * byteSize(t->word(2));
    case spv::Op::OpTypeMatrix: return t->word(3) * byteSize(t->word(2));
    case spv::Op::OpTypeArray: {
      auto n = arrayLength(typeId);
      return n ? static_cast<uint32_t>(*n) * byteSize(t->word(2)) : 0;
    }
    case spv::Op::OpTypeStruct: {
      uint32_t sum = 0;
      for (size_t i = 2; i < t->size(); ++i) {
        uint32_t member = byteSize(t->word(i));
        if (member == 0) return 0;
        sum += member;
      }
      return sum;
    }
    case spv::Op::OpTypePointer:
      return static_cast<spv::StorageClass>(t->word(2)) == spv::StorageClass::PhysicalStorageBuffer ? 8 : 0;
    default: return 0;
  }
}

std::string Types::name(uint32_t typeId) const {
  const Instruction* t = defs_.def(typeId);
  if (t == nullptr) return "?";
  switch (t->opcode()) {
    case spv::Op::OpTypeVoid: return "void";
    case spv::Op::OpTypeBool: return "bool";
    case spv::Op::OpTypeInt: return (t->word(3) ? "i" : "u") + std::to_string(t->word(2));
    case spv::Op::OpTypeFloat: return "f" + std::to_string(t->word(2));
    case spv::Op::OpTypeVector: return "vec" + std::to_string(t->word(3)) + "<" + name(t->word(2)) + ">";
    case spv::Op::OpTypeMatrix: {
      const Instruction* col = defs_.def(t->word(2));
      std::string rows = col ? std::to_string(col->word(3)) : "?";
      std::string comp = col ? name(col->word(2)) : "?";
      return "mat" + std::to_string(t->word(3)) + "x" + rows + "<" + comp + ">";
    }
    case spv::Op::OpTypeArray: {
      auto n = arrayLength(typeId);
      return "array<" + name(t->word(2)) + "," + (n ? std::to_string(*n) : "?") + ">";
    }
    case spv::Op::OpTypeRuntimeArray: return "array<" + name(t->word(2)) + ">";
    case spv::Op::OpTypeStruct: {
      std::string n = defs_.name(typeId);
      return n.empty() ? "struct" : "struct " + n;
    }
    case spv::Op::OpTypePointer: return "ptr<" + name(t->word(3)) + ">";
    case spv::Op::OpTypeImage: return "image";
    case spv::Op::OpTypeSampledImage: return "sampled_image";
    case spv::Op::OpTypeSampler: return "sampler";
    default: return "?";
  }
}

std::optional<uint64_t> Types::constantValue(uint32_t id) const {
  const Instruction* c = defs_.def(id);
  if (c == nullptr || c->opcode() != spv::Op::OpConstant) return std::nullopt;
  const Instruction* t = defs_.def(c->resultType());
  if (t == nullptr || t->opcode() != spv::Op::OpTypeInt) return std::nullopt;
  uint64_t v = c->word(3);
  if (t->word(2) == 64) v |= uint64_t{c->word(4)} << 32;
  return v;
}

std::optional<uint32_t> Types::arrayLength(uint32_t arrayTypeId) const {
  const Instruction* t = defs_.def(arrayTypeId);
  if (t == nullptr || t->opcode() != spv::Op::OpTypeArray) return std::nullopt;
  auto n = constantValue(t->word(3));
  if (!n) return std::nullopt;
  return static_cast<uint32_t>(*n);
}

uint32_t Types::imageType(uint32_t typeId) const {
  const Instruction* t = defs_.def(typeId);
  if (t == nullptr) return 0;
  if (t->opcode() == spv::Op::OpTypeImage) return typeId;
  if (t->opcode() == spv::Op::OpTypeSampledImage) return imageType(t->word(2));
  return 0;
}

bool Types::isSubpassData(uint32_t typeId) const {
  const Instruction* t = defs_.def(imageType(typeId));
  return t != nullptr && static_cast<spv::Dim>(t->word(3)) == spv::Dim::SubpassData;
}

uint32_t imageFormatBytes(spv::ImageFormat format) {
  using F = spv::ImageFormat;
  switch (format) {
    case F::Rgba32f: case F::Rgba32i: case F::Rgba32ui: return 16;
    case F::Rgba16f: case F::Rgba16: case F::Rgba16Snorm: case F::Rgba16i: case F::Rgba16ui:
    case F::Rg32f: case F::Rg32i: case F::Rg32ui: case F::R64ui: case F::R64i: return 8;
    case F::R32f: case F::R32i: case F::R32ui: case F::Rgba8: case F::Rgba8Snorm: case F::Rgba8i:
    case F::Rgba8ui: case F::Rg16f: case F::Rg16: case F::Rg16Snorm: case F::Rg16i: case F::Rg16ui:
    case F::R11fG11fB10f: case F::Rgb10A2: case F::Rgb10a2ui: return 4;
    case F::R16f: case F::R16: case F::R16Snorm: case F::R16i: case F::R16ui: case F::Rg8: case F::Rg8Snorm:
    case F::Rg8i: case F::Rg8ui: return 2;
    case F::R8: case F::R8Snorm: case F::R8i: case F::R8ui: return 1;
    default: return 0;
  }
}

std::string imageFormatName(spv::ImageFormat format) {
  using F = spv::ImageFormat;
  switch (format) {
    case F::Rgba32f: return "rgba32f"; case F::Rgba32i: return "rgba32i"; case F::Rgba32ui: return "rgba32ui";
    case F::Rgba16f: return "rgba16f"; case F::Rgba16: return "rgba16"; case F::Rgba16Snorm: return "rgba16_snorm";
    case F::Rgba16i: return "rgba16i"; case F::Rgba16ui: return "rgba16ui"; case F::Rg32f: return "rg32f";
    case F::Rg32i: return "rg32i"; case F::Rg32ui: return "rg32ui"; case F::R64ui: return "r64ui";
    case F::R64i: return "r64i"; case F::R32f: return "r32f"; case F::R32i: return "r32i";
    case F::R32ui: return "r32ui"; case F::Rgba8: return "rgba8"; case F::Rgba8Snorm: return "rgba8_snorm";
    case F::Rgba8i: return "rgba8i"; case F::Rgba8ui: return "rgba8ui"; case F::Rg16f: return "rg16f";
    case F::Rg16: return "rg16"; case F::Rg16Snorm: return "rg16_snorm"; case F::Rg16i: return "rg16i";
    case F::Rg16ui: return "rg16ui"; case F::R11fG11fB10f: return "r11f_g11f_b10f"; case F::Rgb10A2: return "rgb10_a2";
    case F::Rgb10a2ui: return "rgb10_a2ui"; case F::R16f: return "r16f"; case F::R16: return "r16";
    case F::R16Snorm: return "r16_snorm"; case F::R16i: return "r16i"; case F::R16ui: return "r16ui";
    case F::Rg8: return "rg8"; case F::Rg8Snorm: return "rg8_snorm"; case F::Rg8i: return "rg8i";
    case F::Rg8ui: return "rg8ui"; case F::R8: return "r8"; case F::R8Snorm: return "r8_snorm";
    case F::R8i: return "r8i"; case F::R8ui: return "r8ui";
    default: return "unknown";
  }
}

}  // namespace tally::spirv

// Type queries over a parsed module: sizes, names, constants, images.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "spirv/module.hpp"

namespace tally::spirv {

class Types {
 public:
  explicit Types(const DefIndex& defs) : defs_(defs) {}

  uint32_t typeOf(uint32_t valueId) const;            // result type of a value, 0 if unknown
  bool isPointerType(uint32_t typeId) const;
  uint32_t pointee(uint32_t pointerTypeId) const;     // 0 if not a pointer
  std::optional<spv::StorageClass> storageClass(uint32_t pointerTypeId) const;
  std::optional<spv::StorageClass> storageClassOfValue(uint32_t pointerValueId) const;

  // Logical bytes of a value of this type (what a load or store moves, padding
  // excluded). 0 when unknown (runtime arrays, opaque types).
  uint32_t byteSize(uint32_t typeId) const;
  // "f32", "vec4<f32>", "mat4x4<f32>", "array<u32,8>", "struct Light", ...
  std::string name(uint32_t typeId) const;

  std::optional<uint64_t> constantValue(uint32_t id) const;  // integer OpConstant
  std::optional<uint32_t> arrayLength(uint32_t arrayTypeId) const;  // nullopt for runtime arrays

  // The OpTypeImage behind an image or sampled-image type, 0 otherwise.
  uint32_t imageType(uint32_t typeId) const;
  bool isSubpassData(uint32_t typeId) const;

 private:
  const DefIndex& defs_;
};

// Bytes per texel of a storage-image format, 0 for Unknown.
uint32_t imageFormatBytes(spv::ImageFormat format);
std::string imageFormatName(spv::ImageFormat format);

}  // namespace tally::spirv

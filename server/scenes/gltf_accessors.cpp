// Typed reads of a glTF accessor's elements out of its buffer, with the
// ranges checked again on the data tinygltf read (gltf_check.cpp checked the
// declared sizes).
#include "scenes/gltf_loader.hpp"

#include <algorithm>
#include <cstring>

namespace tally::scenes::detail {

// Reads `components` floats per element of an accessor. Normalized integer
// components are accepted where glTF allows them (texture coordinates).
Result<std::vector<float>> readFloats(const Model& model, int index, int components, bool allowNormalized,
                                      const std::string& what) {
  const std::string where = what + " (accessor " + std::to_string(index) + ")";
  if (index < 0 || size_t(index) >= model.accessors.size()) return makeError(where + ": no such accessor");
  const tinygltf::Accessor& acc = model.accessors[size_t(index)];
  if (acc.sparse.isSparse) return makeError(where + ": sparse accessors are not supported");
  if (tinygltf::GetNumComponentsInType(uint32_t(acc.type)) != components)
    return makeError(where + ": expected " + std::to_string(components) + " components per element");
  if (acc.bufferView < 0 || size_t(acc.bufferView) >= model.bufferViews.size())
    return makeError(where + ": has no buffer view (compressed or missing data)");
  const tinygltf::BufferView& view = model.bufferViews[size_t(acc.bufferView)];
  if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size())
    return makeError(where + ": buffer view refers to missing buffer " + std::to_string(view.buffer));
  const tinygltf::Buffer& buffer = model.buffers[size_t(view.buffer)];
  const int componentSize = tinygltf::GetComponentSizeInBytes(uint32_t(acc.componentType));
  const int stride = acc.ByteStride(view);
  if (componentSize <= 0 || stride <= 0) return makeError(where + ": invalid component type or stride");
  const size_t elementSize = size_t(componentSize) * size_t(components);
  const size_t start = view.byteOffset + acc.byteOffset;
  const size_t limit = std::min(view.byteOffset + view.byteLength, buffer.data.size());
  if (size_t(stride) < elementSize)
    return makeError(where + ": byteStride " + std::to_string(stride) + " is smaller than its element (" +
                     std::to_string(elementSize) + " bytes)");
  size_t span = 0;  // overflow-checked: a huge count must not wrap past the check and allocate
  if (acc.count > 0 && (__builtin_mul_overflow(size_t(stride), acc.count - 1, &span) ||
                        __builtin_add_overflow(span, start + elementSize, &span) || span > limit))
    return makeError(where + ": reads past the end of buffer " + std::to_string(view.buffer) +
                     (buffer.data.empty() ? " (the buffer has no data)" : ""));

  const int type = acc.componentType;
  const bool normalizedInt =
      allowNormalized && acc.normalized &&
      (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE || type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
  if (type != TINYGLTF_COMPONENT_TYPE_FLOAT && !normalizedInt)
    return makeError(where + ": unsupported component type " + std::to_string(type) +
                     (acc.normalized ? " (normalized)" : ""));

  std::vector<float> out(acc.count * size_t(components));
  const unsigned char* base = buffer.data.data() + start;
  for (size_t i = 0; i < acc.count; ++i) {
    const unsigned char* e = base + i * size_t(stride);
    for (int c = 0; c < components; ++c) {
      const unsigned char* p = e + size_t(c) * size_t(componentSize);
      float v = 0.0f;
      if (type == TINYGLTF_COMPONENT_TYPE_FLOAT) {
        std::memcpy(&v, p, 4);
      } else if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
        v = float(*p) / 255.0f;
      } else {
        uint16_t u16;
        std::memcpy(&u16, p, 2);
        v = float(u16) / 65535.0f;
      }
      out[i * size_t(components) + size_t(c)] = v;
    }
  }
  return out;
}

Result<std::vector<uint32_t>> readIndices(const Model& model, int index, size_t vertexCount,
                                          const std::string& what) {
  const std::string where = what + " indices (accessor " + std::to_string(index) + ")";
  if (index < 0 || size_t(index) >= model.accessors.size()) return makeError(where + ": no such accessor");
  const tinygltf::Accessor& acc = model.accessors[size_t(index)];
  if (acc.sparse.isSparse) return makeError(where + ": sparse accessors are not supported");
  size_t size = 0;
  switch (acc.componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: size = 1; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: size = 2; break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: size = 4; break;
    default:
      return makeError(where + ": unsupported index component type " + std::to_string(acc.componentType) +
                       " (glTF allows unsigned byte, short or int)");
  }
  if (acc.type != TINYGLTF_TYPE_SCALAR) return makeError(where + ": indices must be scalars");
  if (acc.bufferView < 0 || size_t(acc.bufferView) >= model.bufferViews.size())
    return makeError(where + ": has no buffer view (compressed or missing data)");
  const tinygltf::BufferView& view = model.bufferViews[size_t(acc.bufferView)];
  if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size())
    return makeError(where + ": buffer view refers to missing buffer " + std::to_string(view.buffer));
  const tinygltf::Buffer& buffer = model.buffers[size_t(view.buffer)];
  const int stride = acc.ByteStride(view);
  if (stride <= 0) return makeError(where + ": invalid stride");
  const size_t start = view.byteOffset + acc.byteOffset;
  const size_t limit = std::min(view.byteOffset + view.byteLength, buffer.data.size());
  size_t span = 0;  // overflow-checked, as readFloats
  if (acc.count > 0 && (size_t(stride) < size || __builtin_mul_overflow(size_t(stride), acc.count - 1, &span) ||
                        __builtin_add_overflow(span, start + size, &span) || span > limit))
    return makeError(where + ": reads past the end of buffer " + std::to_string(view.buffer) +
                     (buffer.data.empty() ? " (the buffer has no data)" : ""));
  std::vector<uint32_t> out(acc.count);
  const unsigned char* base = buffer.data.data() + start;
  for (size_t i = 0; i < acc.count; ++i) {
    const unsigned char* p = base + i * size_t(stride);
    uint32_t v = 0;
    if (size == 1) v = *p;
    if (size == 2) {
      uint16_t s;
      std::memcpy(&s, p, 2);
      v = s;
    }
    if (size == 4) std::memcpy(&v, p, 4);
    if (v >= vertexCount)
      return makeError(where + ": index " + std::to_string(v) + " out of range (" +
                       std::to_string(vertexCount) + " vertices)");
    out[i] = v;
  }
  return out;
}

}  // namespace tally::scenes::detail

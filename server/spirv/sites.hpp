// The site table: what the instrumentation found and where it counts it.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace tally::spirv {

// Shader stage of the entry point that reaches a site.
enum class Stage { Vertex, TessControl, TessEval, Geometry, Fragment, Compute, Task, Mesh, Other };

// What kind of access a site is; see docs/measurement.md for the byte model.
enum class SiteKind {
  TextureRead,     // OpImageSample*/Fetch/Gather/Read (+ sparse), not on SubpassData
  AttachmentRead,  // subpassLoad: OpImageRead on a SubpassData image
  ImageWrite,      // OpImageWrite
  ImageAtomic,     // OpAtomic* through OpImageTexelPointer
  BufferRead,      // OpLoad / OpAtomicLoad / OpCopyMemory source through a buffer pointer
  BufferWrite,     // OpStore / OpAtomicStore / atomic RMW / OpCopyMemory target through a buffer pointer
  OutputWrite,     // fragment output per Location, counted once per invocation that returns
  Invocation,      // one per entry point, counted on entry
};

std::string_view toString(Stage stage);
std::string_view toString(SiteKind kind);
std::optional<SiteKind> siteKindFromString(std::string_view name);

struct Site;
// How a site uses its resource, as a result line's kind: "texture" (sampled
// or fetched), "storage image" (OpImageRead outside subpass data, image
// writes and atomics), "attachment" (input attachments, fragment outputs),
// "buffer" (vertex attributes too). The caller, who knows what is bound,
// says "buffer" for a texel buffer and "depth" for a depth input attachment.
std::string_view useKind(const Site& site);
std::optional<Stage> stageFromString(std::string_view name);

struct Site {
  uint32_t slot = 0;        // first counter slot (a 64-bit counter) of this site's resource
  uint32_t slotCount = 1;   // >1 when the descriptor array index is dynamic: one slot per element
  Stage stage = Stage::Other;
  std::string entryPoint;
  SiteKind kind = SiteKind::Invocation;
  // Resource. set/binding are -1 where there is none (invocation, output_write,
  // PhysicalStorageBuffer pointers) or it could not be resolved.
  int64_t set = -1;
  int64_t binding = -1;
  std::optional<uint32_t> index;  // constant descriptor array index
  bool dynamicIndex = false;      // index known only at run time (slot + index)
  // A physical-storage-buffer access counted by address
  // (InstrumentOptions::addressTable): slot + spirv::kAddressUnknownSlot
  // for an address in no known range, + kAddressOtherSlot for buffers
  // beyond those with slots of their own, then one slot per such buffer.
  bool byAddress = false;
  std::string resource;           // OpName of the variable, or "physical_storage_buffer"
  std::optional<uint32_t> location;  // output_write: the fragment output Location
  // Element accessed, where known: for buffers the loaded/stored type, for
  // images the declared format (sampled images: the format of the bound view
  // decides, elementBytes is 0).
  std::string elementType;
  uint32_t elementBytes = 0;
  // Footprint: the instrumentation marks this site's blocks (false where
  // footprint is off or the access is one the model does not cover; a note says which).
  bool footprint = false;
  std::string opcode;  // the instruction that accesses memory, e.g. "OpImageSampleImplicitLod"
  std::string file;    // from OpLine or NonSemantic.Shader.DebugInfo.100's DebugLine, when present
  uint32_t line = 0;
  // InstrumentOptions::perSite: the function holding the access (its OpName,
  // or "%id"), the instruction's position in the module as instrumented from
  // (0-based after the header: spirv-dis --no-header's line) and its text,
  // for a reader without line information. Output writes: the first store
  // to the output.
  std::string function;
  uint32_t instruction = 0;
  std::string disassembly;
  // The shader the module came from, as its owner names it (a GLSL file, a
  // module's debug name): set by the caller, not the instrumentation.
  std::string shader;
};

}  // namespace tally::spirv

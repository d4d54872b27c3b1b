// Footprint: mark the blocks each access covers.
//
// Straight-line code at the site computes what the access touches (a
// buffer's byte offset, an image's coordinates and level of detail) and
// calls one of the tally_fp_* functions, which read the slot's table entry
// (spirv/footprint.hpp) and set the blocks' bits: a load first, and the
// atomic OR only where the bit is still clear, so a block touched again
// costs a read of a cached word. Branches live in those functions only:
// the code at a site never splits the site's block.

#include "spirv/injector.hpp"

#include <algorithm>

#include "spirv/footprint.hpp"

namespace tally::spirv {

// The terms of a buffer pointer's byte offset from the start of its
// descriptor's buffer (the element of a descriptor array); nullopt with
// `why` set where the chain cannot be followed.
std::optional<Injector::OffsetTerms> Injector::offsetTerms(uint32_t pointer, int function, std::string& why) {
  std::vector<const Instruction*> chain;
  uint32_t variable = 0;
  for (int depth = 0; depth < 64 && variable == 0; ++depth) {
    const Instruction* d = defs_.def(pointer);
    if (d == nullptr) break;
    switch (d->opcode()) {
      case spv::Op::OpVariable: variable = pointer; break;
      case spv::Op::OpAccessChain:
      case spv::Op::OpInBoundsAccessChain:
        if (defs_.functionOf(pointer) != function) {
          why = "buffer accesses through pointers made in another function";
          return std::nullopt;
        }
        chain.push_back(d);
        pointer = d->word(3);
        break;
      case spv::Op::OpCopyObject: pointer = d->word(3); break;
      default:
        why = std::string("buffer accesses through ") +
              (d->opcode() == spv::Op::OpFunctionParameter ? "function parameters" : "pointer arithmetic");
        return std::nullopt;
    }
  }
  if (variable == 0) {
    why = "buffer accesses whose pointer has no variable";
    return std::nullopt;
  }
  std::reverse(chain.begin(), chain.end());
  uint32_t type = types_.pointee(defs_.def(variable)->resultType());
  bool descriptorArray = false;
  if (const Instruction* t = defs_.def(type); t && (t->opcode() == spv::Op::OpTypeArray || t->opcode() == spv::Op::OpTypeRuntimeArray)) {
    descriptorArray = !defs_.decorationValue(type, spv::Decoration::ArrayStride).has_value();
  }
  OffsetTerms terms;
  uint64_t& constantPart = terms.constant;
  std::optional<uint32_t> matrixStride;
  bool rowMajor = false;
  auto addDynamic = [&](uint32_t index, uint32_t stride) { terms.dynamic.push_back({index, stride}); };
  bool first = true;
  for (const Instruction* ac : chain) {
    for (size_t w = 4; w < ac->size(); ++w) {
      uint32_t index = ac->word(w);
      const Instruction* t = defs_.def(type);
      if (t == nullptr) {
        why = "buffer accesses into an unknown type";
        return std::nullopt;
      }
      auto constIndex = types_.constantValue(index);
      if (first && descriptorArray) {  // the descriptor, not a byte offset
        type = t->word(2);
        first = false;
        continue;
      }
      first = false;
      switch (t->opcode()) {
        case spv::Op::OpTypeStruct: {
          if (!constIndex) {
            why = "buffer accesses with a run-time struct member";
            return std::nullopt;
          }
          uint32_t m = static_cast<uint32_t>(*constIndex);
          constantPart += defs_.memberDecorationValue(type, m, spv::Decoration::Offset).value_or(0);
          matrixStride = defs_.memberDecorationValue(type, m, spv::Decoration::MatrixStride);
          rowMajor = false;
          for (const auto& dec : defs_.memberDecorations(type, m)) {
            if (dec.kind == spv::Decoration::RowMajor) rowMajor = true;
          }
          type = t->word(2 + m);
          break;
        }
        case spv::Op::OpTypeArray:
        case spv::Op::OpTypeRuntimeArray: {
          auto stride = defs_.decorationValue(type, spv::Decoration::ArrayStride);
          if (!stride) {
            why = "buffer accesses into arrays without an ArrayStride";
            return std::nullopt;
          }
          if (constIndex) constantPart += *constIndex * *stride; else addDynamic(index, *stride);
          type = t->word(2);
          break;
        }
        case spv::Op::OpTypeMatrix: {
          if (!matrixStride || rowMajor) {
            why = "buffer accesses to columns of row-major matrices";
            return std::nullopt;
          }
          if (constIndex) constantPart += *constIndex * *matrixStride; else addDynamic(index, *matrixStride);
          type = t->word(2);
          break;
        }
        case spv::Op::OpTypeVector: {
          uint32_t bytes = types_.byteSize(t->word(2));
          if (constIndex) constantPart += *constIndex * bytes; else addDynamic(index, bytes);
          type = t->word(2);
          break;
        }
        default:
          why = "buffer accesses into an unknown type";
          return std::nullopt;
      }
    }
  }
  return terms;
}

// The offset as straight-line code; an index found in `replace` is replaced
// by its value there.
uint32_t Injector::emitOffset(Body& b, const OffsetTerms& terms, const std::map<uint32_t, uint32_t>& replace) {
  uint32_t u = tU32();
  uint32_t dynamicPart = 0;
  for (auto [index, stride] : terms.dynamic) {
    auto r = replace.find(index);
    uint32_t value = intAs(b, r != replace.end() ? r->second : index, false);
    uint32_t term = op(b, spv::Op::OpIMul, u, {value, constantU32(stride)});
    dynamicPart = dynamicPart == 0 ? term : op(b, spv::Op::OpIAdd, u, {dynamicPart, term});
  }
  uint32_t offset = constantU32(static_cast<uint32_t>(terms.constant));
  return dynamicPart == 0 ? offset : op(b, spv::Op::OpIAdd, u, {dynamicPart, offset});
}

// The pointer a buffer site accesses.
uint32_t Injector::sitePointer(const FoundSite& s) const {
  const Instruction& inst = m_.functions[s.function].insts[s.instruction];
  spv::Op o = inst.opcode();
  if (o == spv::Op::OpLoad) return inst.word(3);
  if (o == spv::Op::OpStore || o == spv::Op::OpAtomicStore) return inst.word(1);
  if (o == spv::Op::OpCopyMemory || o == spv::Op::OpCopyMemorySized) {
    return s.site.kind == SiteKind::BufferRead ? inst.word(2) : inst.word(1);
  }
  return inst.word(3);  // the other atomics
}

// The pixel of a fragment invocation: floor(FragCoord.xy) as i32.
std::pair<uint32_t, uint32_t> Injector::fragmentPixel(Body& b, Stage stage) {
  uint32_t v4 = tVec(tF32(), 4), i = tI32();
  uint32_t coord = op(b, spv::Op::OpLoad, v4, {builtin(stage, spv::BuiltIn::FragCoord, v4)});
  uint32_t x = op(b, spv::Op::OpConvertFToS, i, {ext(b, tF32(), Floor, {op(b, spv::Op::OpCompositeExtract, tF32(), {coord, 0})})});
  uint32_t y = op(b, spv::Op::OpConvertFToS, i, {ext(b, tF32(), Floor, {op(b, spv::Op::OpCompositeExtract, tF32(), {coord, 1})})});
  return {x, y};
}

// The image operands of an image instruction from word `at`: operand ids by mask bit.
std::map<uint32_t, std::vector<uint32_t>> Injector::imageOperands(const Instruction& inst, size_t at) {
  std::map<uint32_t, std::vector<uint32_t>> out;
  if (inst.size() <= at) return out;
  uint32_t mask = inst.word(at);
  size_t w = at + 1;
  for (uint32_t bit = 0; bit < 32; ++bit) {
    uint32_t m = 1u << bit;
    if ((mask & m) == 0) continue;
    uint32_t n = 0;
    switch (m) {
      case 0x1: case 0x2: case 0x8: case 0x10: case 0x20: case 0x40: case 0x80: case 0x100: case 0x200:
      case 0x10000: n = 1; break;
      case 0x4: n = 2; break;
      default: n = 0; break;
    }
    std::vector<uint32_t> ids;
    for (uint32_t k = 0; k < n; ++k) ids.push_back(inst.word(w++));
    out.emplace(m, std::move(ids));
  }
  return out;
}

Injector::TexelCoords Injector::texelCoords(Body& b, uint32_t coord, uint32_t dim, bool arrayed) {
  tI32();  // made first, as before coordinates were converted by type
  auto c = [&](uint32_t k) { return intComponent(b, coord, k, true); };
  bool twoD = dim != uint32_t(spv::Dim::Dim1D);
  uint32_t x = c(0);
  uint32_t y = twoD ? c(1) : constantI32(0);
  uint32_t layer = arrayed ? c(twoD ? 2 : 1) : constantI32(0);
  return {x, y, layer};
}

// Emits the marking of one site; false (with `why`) where the model does
// not cover the access.
bool Injector::emitFootprint(Body& b, const FoundSite& s, uint32_t entry, Stage stage, std::string& why) {
  const Site& site = s.site;
  // Made first and in this order whatever the access: the output's ids follow from it.
  tU32();
  tI32();
  tF32();
  if (site.kind == SiteKind::OutputWrite) {
    if ((options_.study & kStudyFpNoOutputs) != 0) return true;
    auto [x, y] = fragmentPixel(b, stage);
    fnCall(b, fpTexelFn(FpMarkKind::Output), {entry, x, y, constantI32(0), constantU32(0)});
    return true;
  }
  if ((site.kind == SiteKind::BufferRead || site.kind == SiteKind::BufferWrite) && site.location) {
    if (stage != Stage::Vertex || site.elementBytes == 0) {
      why = "vertex inputs of unknown size";
      return false;
    }
    uint32_t vertex = loadIntAsU32(b, builtin(stage, spv::BuiltIn::VertexIndex, tI32(), true));
    fnCall(b, fpBytesFn(shortBytes(site.elementBytes)), {entry, vertex, constantU32(site.elementBytes)});
    return true;
  }
  if (site.kind == SiteKind::BufferRead || site.kind == SiteKind::BufferWrite) {
    if (site.elementBytes == 0) {
      why = "buffer accesses of unknown size";
      return false;
    }
    auto terms = offsetTerms(sitePointer(s), s.function, why);
    if (!terms) return false;
    fnCall(b, fpBytesFn(shortBytes(site.elementBytes)), {entry, emitOffset(b, *terms), constantU32(site.elementBytes)});
    return true;
  }
  const Instruction& inst = m_.functions[s.function].insts[s.instruction];
  return emitImageFootprint(b, s, inst, entry, stage, why);
}

// Images: the OpTypeImage behind the accessed image.
bool Injector::emitImageFootprint(Body& b, const FoundSite& s, const Instruction& inst, uint32_t entry, Stage stage,
                                  std::string& why) {
  const Site& site = s.site;
  const uint32_t i = tI32();
  spv::Op o = inst.opcode();
  uint32_t imageValue = 0, coord = 0;
  if (site.kind == SiteKind::ImageAtomic) {
    const Instruction* tp = defs_.def(inst.word(3));
    while (tp != nullptr && tp->opcode() == spv::Op::OpCopyObject) tp = defs_.def(tp->word(3));
    if (tp == nullptr || tp->opcode() != spv::Op::OpImageTexelPointer) {
      why = "image atomics through an unknown pointer";
      return false;
    }
    const Instruction* imageType = defs_.def(types_.imageType(types_.pointee(types_.typeOf(tp->word(3)))));
    if (!texelImage(imageType, why)) return false;
    TexelCoords c = texelCoords(b, tp->word(4), imageType->word(3), imageType->word(5) != 0);
    fnCall(b, fpTexelFn(), {entry, c.x, c.y, c.layer, constantU32(0)});
    return true;
  }
  if (site.kind == SiteKind::AttachmentRead) {
    auto [x, y] = fragmentPixel(b, stage);
    uint32_t ox = intComponent(b, inst.word(4), 0, true);
    uint32_t oy = intComponent(b, inst.word(4), 1, true);
    fnCall(b, fpTexelFn(), {entry, op(b, spv::Op::OpIAdd, i, {x, ox}), op(b, spv::Op::OpIAdd, i, {y, oy}),
                            constantI32(0), constantU32(0)});
    return true;
  }
  imageValue = o == spv::Op::OpImageWrite ? inst.word(1) : inst.word(3);
  coord = o == spv::Op::OpImageWrite ? inst.word(2) : inst.word(4);
  const Instruction* imageType = defs_.def(types_.imageType(types_.typeOf(imageValue)));
  if (!texelImage(imageType, why)) return false;
  const uint32_t dim = imageType->word(3);
  const bool arrayed = imageType->word(5) != 0;
  const bool fetch = o == spv::Op::OpImageFetch || o == spv::Op::OpImageSparseFetch;
  if (o == spv::Op::OpImageWrite || o == spv::Op::OpImageRead || o == spv::Op::OpImageSparseRead || fetch) {
    TexelCoords c = texelCoords(b, coord, dim, arrayed);
    uint32_t lod = constantU32(0);
    if (fetch) {
      auto ops = imageOperands(inst, 5);
      if (auto l = ops.find(0x2); l != ops.end()) lod = intAs(b, l->second[0], false);
      for (uint32_t bit : {0x8u, 0x10u}) {
        if (auto off = ops.find(bit); off != ops.end()) {
          c.x = op(b, spv::Op::OpIAdd, i, {c.x, intComponent(b, off->second[0], 0, true)});
          if (dim != uint32_t(spv::Dim::Dim1D)) {
            c.y = op(b, spv::Op::OpIAdd, i, {c.y, intComponent(b, off->second[0], 1, true)});
          }
        }
      }
    }
    fnCall(b, fpTexelFn(), {entry, c.x, c.y, c.layer, lod});
    return true;
  }
  return emitFilteredFootprint(b, s, inst, entry, stage, coord, imageType, why);
}

// Filtered reads: the level (given, from gradients or queried) and the
// filter's texels are worked out by the tally_fp_sample helper.
bool Injector::emitFilteredFootprint(Body& b, const FoundSite& s, const Instruction& inst, uint32_t entry, Stage stage,
                                     uint32_t coord, const Instruction* imageType, std::string& why) {
  if ((options_.study & kStudyFpNoSamples) != 0) return true;
  // Made in this order whatever the access: the output's ids follow from it.
  const uint32_t u = tU32();
  tI32();
  const uint32_t fl = tF32();
  const uint32_t dim = imageType->word(3);
  const bool arrayed = imageType->word(5) != 0;
  size_t operandsAt = 0;
  const std::string& name = s.site.opcode;
  const bool dref = name.find("Dref") != std::string::npos;
  const bool proj = name.find("Proj") != std::string::npos;
  const bool gather = name.find("Gather") != std::string::npos;
  const bool implicit = name.find("ImplicitLod") != std::string::npos;
  operandsAt = (dref || gather) ? 6 : 5;
  auto ops = imageOperands(inst, operandsAt);
  if (ops.count(0x20) || ops.count(0x10000)) {
    why = "gathers with per-texel offsets";
    return false;
  }
  const bool twoD = dim != uint32_t(spv::Dim::Dim1D);
  uint32_t uc = component(b, coord, 0, fl);
  uint32_t vc = twoD ? component(b, coord, 1, fl) : constantF32(0.5f);
  uint32_t layer = arrayed ? component(b, coord, twoD ? 2 : 1, fl) : constantF32(0.0f);
  if (proj) {
    uint32_t q = component(b, coord, componentCount(coord) - 1, fl);
    uc = op(b, spv::Op::OpFDiv, fl, {uc, q});
    if (twoD) vc = op(b, spv::Op::OpFDiv, fl, {vc, q});
  }
  uint32_t lodKind = uint32_t(Lod::Explicit), a = constantF32(0.0f), lambda = constantF32(0.0f);
  if (gather) {
    lodKind = uint32_t(Lod::Gather);
  } else if (auto l = ops.find(0x2); l != ops.end()) {
    a = l->second[0];
  } else if (auto g = ops.find(0x4); g != ops.end()) {
    // lambda = log2(max(|dPdx * size|, |dPdy * size|)) at the view's first level.
    uint32_t base = tableWord(b, entry, footprint::kBaseLevel);
    auto size = [&](uint32_t word) {
      uint32_t n = ext(b, u, UMax, {op(b, spv::Op::OpShiftRightLogical, u, {tableWord(b, entry, word), base}), constantU32(1)});
      return op(b, spv::Op::OpConvertUToF, fl, {n});
    };
    uint32_t w = size(footprint::kWidth), h = size(footprint::kHeight);
    auto rho = [&](uint32_t d) {
      uint32_t dx = op(b, spv::Op::OpFMul, fl, {component(b, d, 0, fl), w});
      if (!twoD) return ext(b, fl, Length, {dx});
      uint32_t dy = op(b, spv::Op::OpFMul, fl, {component(b, d, 1, fl), h});
      return ext(b, fl, Length, {op(b, spv::Op::OpCompositeConstruct, tF32v(2), {dx, dy})});
    };
    a = ext(b, fl, Log2, {ext(b, fl, FMax, {rho(g->second[0]), rho(g->second[1])})});
  } else if (implicit && stage == Stage::Fragment) {
    addCapability(spv::Capability::ImageQuery);
    uint32_t queryCoord = twoD ? op(b, spv::Op::OpCompositeConstruct, tF32v(2), {uc, vc}) : uc;
    uint32_t q = op(b, spv::Op::OpImageQueryLod, tF32v(2), {inst.word(3), queryCoord});
    a = op(b, spv::Op::OpCompositeExtract, fl, {q, 0});
    lambda = op(b, spv::Op::OpCompositeExtract, fl, {q, 1});
    lodKind = uint32_t(Lod::Queried);
    if (auto bias = ops.find(0x1); bias != ops.end()) {
      // The shader's bias moves lambda; the level follows it, clamped by the sampler helper.
      a = op(b, spv::Op::OpFAdd, fl, {lambda, bias->second[0]});
      lodKind = uint32_t(Lod::Explicit);
    }
  }
  uint32_t ox = constantI32(0), oy = constantI32(0);
  for (uint32_t bit : {0x8u, 0x10u}) {
    if (auto off = ops.find(bit); off != ops.end()) {
      ox = intComponent(b, off->second[0], 0, true);
      if (twoD) oy = intComponent(b, off->second[0], 1, true);
    }
  }
  fnCall(b, fpSampleFn(), {entry, uc, vc, layer, constantU32(lodKind), a, lambda, ox, oy});
  return true;
}

// 1D and 2D images (arrayed or not, any sample count); others are not modelled.
bool Injector::texelImage(const Instruction* imageType, std::string& why) {
  if (imageType == nullptr) {
    why = "accesses to images of unknown type";
    return false;
  }
  auto dim = static_cast<spv::Dim>(imageType->word(3));
  if (dim == spv::Dim::Dim1D || dim == spv::Dim::Dim2D) return true;
  static const std::map<spv::Dim, const char*> names = {{spv::Dim::Dim3D, "3D"}, {spv::Dim::Cube, "cube"},
                                                        {spv::Dim::Rect, "rect"}, {spv::Dim::Buffer, "texel buffer"},
                                                        {spv::Dim::SubpassData, "subpass"}};
  auto it = names.find(dim);
  why = std::string("accesses to ") + (it != names.end() ? it->second : "other") + " images";
  return false;
}

// Emits the site's marking where its count goes; result_.sites[index].footprint says whether it did.
void Injector::footprintSite(size_t index, const FoundSite& s, const EntryPoint& ep, uint32_t slotBase,
                   std::vector<std::map<size_t, std::vector<Instruction>>>& after,
                   std::vector<std::map<size_t, std::vector<Instruction>>>& before) {
  if (s.site.kind == SiteKind::Invocation) return;
  if (s.site.set < 0 && !s.site.location && s.site.kind != SiteKind::OutputWrite) {
    noteOnce("footprint: " + std::string(toString(s.site.kind)) + " of " + s.site.resource + " not measured");
    return;
  }
  if (footprintLoopRange(s, slotBase, before)) {
    result_.sites[index].footprint = true;
    ++fpLoopSites_[ep.stage];
    return;
  }
  const auto& insts = m_.functions[s.function].insts;
  std::string why;
  auto emitInto = [&](std::vector<Instruction>& list) {
    std::vector<Instruction> code;
    Body b{code};
    uint32_t slot = slotValue(s, slotBase, code);
    uint32_t entry = op(b, spv::Op::OpIMul, tU32(), {slot, constantU32(footprint::kEntryWords)});
    if (!emitFootprint(b, s, entry, ep.stage, why)) return false;
    list.insert(list.end(), code.begin(), code.end());
    return true;
  };
  bool done = false;
  switch (s.placement) {
    case Placement::AfterInstruction: done = emitInto(after[s.function][s.instruction]); break;
    case Placement::EntryStart: done = emitInto(before[s.function][entryStart(insts)]); break;
    case Placement::BeforeReturns:
      done = true;
      for (size_t at = 0; at < insts.size() && done; ++at) {
        if (insts[at].opcode() == spv::Op::OpReturn) done = emitInto(before[s.function][at]);
      }
      break;
  }
  if (done) {
    result_.sites[index].footprint = true;
  } else {
    noteOnce("footprint: " + why + " not measured");
  }
}

}  // namespace tally::spirv

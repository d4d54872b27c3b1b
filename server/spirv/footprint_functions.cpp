// Footprint: the tally_fp_* functions the code at each site calls
// (footprint_sites.cpp), which find and set the bits of the blocks an access
// covers from the slot's table entry (spirv/footprint.hpp).

#include "spirv/injector.hpp"

#include "spirv/footprint.hpp"

namespace tally::spirv {

// Two u32 runtime-array buffers: the table and the bitmaps.
void Injector::declareFootprint() {
  bool storageBuffer = m_.version >= kVersion13;
  uint32_t array = m_.newId();
  newGlobals_.emplace_back(spv::Op::OpTypeRuntimeArray, std::vector<uint32_t>{array, tU32()});
  decorate(array, spv::Decoration::ArrayStride, {4});
  uint32_t block = m_.newId();
  newGlobals_.emplace_back(spv::Op::OpTypeStruct, std::vector<uint32_t>{block, array});
  decorate(block, storageBuffer ? spv::Decoration::Block : spv::Decoration::BufferBlock);
  newAnnotations_.emplace_back(spv::Op::OpMemberDecorate,
                               std::vector<uint32_t>{block, 0, static_cast<uint32_t>(spv::Decoration::Offset), 0});
  name(block, "TallyFootprintWords");
  uint32_t blockPtr = tPtr(storageClass_, block);
  auto variable = [&](uint32_t binding, const char* varName) {
    uint32_t id = m_.newId();
    newGlobals_.emplace_back(spv::Op::OpVariable,
                             std::vector<uint32_t>{blockPtr, id, static_cast<uint32_t>(storageClass_)});
    decorate(id, spv::Decoration::DescriptorSet, {options_.set});
    decorate(id, spv::Decoration::Binding, {binding});
    name(id, varName);
    return id;
  };
  fpTable_ = variable(options_.footprintTableBinding, "tally_footprint_table");
  fpBitmap_ = variable(options_.footprintBitmapBinding, "tally_footprint_bitmap");
  fpWordPtr_ = tPtr(storageClass_, tU32());
  // Neither buffer is the other, and the shader never writes the table: a
  // driver may keep the table's words across the bitmap's atomics.
  if ((options_.study & kStudyFpAliased) == 0) {
    decorate(fpTable_, spv::Decoration::NonWritable);
    decorate(fpTable_, spv::Decoration::Restrict);
    decorate(fpBitmap_, spv::Decoration::Restrict);
  }
}

uint32_t Injector::tableWord(Body& b, uint32_t entry, uint32_t word) {
  uint32_t index = word == 0 ? entry : op(b, spv::Op::OpIAdd, tU32(), {entry, constantU32(word)});
  uint32_t ptr = op(b, spv::Op::OpAccessChain, fpWordPtr_, {fpTable_, constantU32(0), index});
  return op(b, spv::Op::OpLoad, tU32(), {ptr});
}

uint32_t Injector::tableWordAt(Body& b, uint32_t entry, uint32_t word, uint32_t dynamicOffset) {
  uint32_t index = op(b, spv::Op::OpIAdd, tU32(), {entry, constantU32(word)});
  index = op(b, spv::Op::OpIAdd, tU32(), {index, dynamicOffset});
  uint32_t ptr = op(b, spv::Op::OpAccessChain, fpWordPtr_, {fpTable_, constantU32(0), index});
  return op(b, spv::Op::OpLoad, tU32(), {ptr});
}

// tally_fp_bytes(entry, offset, bytes): the blocks of bytes [offset, offset + bytes)
// of a Buffer entry, or of vertex `offset` (the vertex index) of a VertexInput entry.
uint32_t Injector::fpBytesFn(bool shortRange) {
  uint32_t& cached = shortRange ? fpBytesShort_ : fpBytes_;
  if (cached != 0) return cached;
  uint32_t u = tU32();
  auto f = beginFunction({u, u, u});
  Body b{f->fn.insts};
  uint32_t entry = f->params[0], offset = f->params[1], bytes = f->params[2];
  // The loop counter: a Function variable, declared first.
  uint32_t counter = 0;
  if (!shortRange) {
    counter = functionVariable(b, u);
  }
  uint32_t kind = tableWord(b, entry, footprint::kKind);
  uint32_t isBuffer = op(b, spv::Op::OpIEqual, tBool(), {kind, constantU32(uint32_t(footprint::EntryKind::Buffer))});
  uint32_t isVertex =
      op(b, spv::Op::OpIEqual, tBool(), {kind, constantU32(uint32_t(footprint::EntryKind::VertexInput))});
  returnIf(b, op(b, spv::Op::OpLogicalNot, tBool(), {op(b, spv::Op::OpLogicalOr, tBool(), {isBuffer, isVertex})}));
  uint32_t stride = tableWord(b, entry, footprint::kTexelBytes), attr = tableWord(b, entry, footprint::kWidth);
  uint32_t vertexOffset = op(b, spv::Op::OpIAdd, u, {op(b, spv::Op::OpIMul, u, {offset, stride}), attr});
  uint32_t start = op(b, spv::Op::OpSelect, u, {isVertex, vertexOffset, offset});
  uint32_t shift = constantU32(static_cast<uint32_t>(std::countr_zero(options_.footprintBlockBytes)));
  uint32_t first = op(b, spv::Op::OpShiftRightLogical, u, {start, shift});
  uint32_t endByte = op(b, spv::Op::OpIAdd, u, {start, op(b, spv::Op::OpISub, u, {bytes, constantU32(1)})});
  uint32_t last = op(b, spv::Op::OpShiftRightLogical, u, {endByte, shift});
  uint32_t base = tableWord(b, entry, footprint::kBase), cap = tableWord(b, entry, footprint::kCapacity);
  if (shortRange) {
    // At most three blocks (bytes <= 2 x block + 1): first, the next, last;
    // no loop, which compilers (lavapipe's LLVM) analyse far faster inside
    // the shader's own loops.
    // A block marked again is skipped: most accesses lie in one block.
    uint32_t second = ext(b, u, UMin, {op(b, spv::Op::OpIAdd, u, {first, constantU32(1)}), last});
    uint32_t mark = fpMarkFn(fpCombine(FpMarkKind::Bytes), (options_.study & kStudyFpRed) != 0);
    fnCall(b, mark, {base, cap, first});
    when(b, op(b, spv::Op::OpINotEqual, tBool(), {second, first}),
         [&](Body& bb) { fnCall(bb, mark, {base, cap, second}); });
    when(b, op(b, spv::Op::OpINotEqual, tBool(), {last, second}),
         [&](Body& bb) { fnCall(bb, mark, {base, cap, last}); });
    cached = endFunction(std::move(f), "tally_fp_bytes_short");
    return cached;
  }
  opNoResult(b, spv::Op::OpStore, {counter, first});
  uint32_t i = 0;
  whileLoop(
      b,
      [&](Body& bb) {
        i = op(bb, spv::Op::OpLoad, u, {counter});
        return op(bb, spv::Op::OpULessThanEqual, tBool(), {i, last});
      },
      [&](Body& bb) { fnCall(bb, fpMarkFn(fpCombine(FpMarkKind::Bytes), (options_.study & kStudyFpRed) != 0), {base, cap, i}); },
      [&](Body& bb) { opNoResult(bb, spv::Op::OpStore, {counter, op(bb, spv::Op::OpIAdd, u, {i, constantU32(1)})}); });
  cached = endFunction(std::move(f), "tally_fp_bytes");
  return cached;
}

Injector::LevelBlocks Injector::levelBlocks(Body& b, uint32_t entry, uint32_t level, uint32_t layer) {
  uint32_t u = tU32(), i = tI32();
  LevelBlocks g{};
  auto size = [&](uint32_t word) {
    return ext(b, u, UMax, {op(b, spv::Op::OpShiftRightLogical, u, {tableWord(b, entry, word), level}), constantU32(1)});
  };
  g.width = size(footprint::kWidth);
  g.height = size(footprint::kHeight);
  uint32_t tw = tableWord(b, entry, footprint::kTileWidth), th = tableWord(b, entry, footprint::kTileHeight);
  g.shiftX = ext(b, u, FindILsb, {tw});
  g.shiftY = ext(b, u, FindILsb, {th});
  g.tilesX = op(b, spv::Op::OpShiftRightLogical, u,
                {op(b, spv::Op::OpIAdd, u, {g.width, op(b, spv::Op::OpISub, u, {tw, constantU32(1)})}), g.shiftX});
  uint32_t lastLayer = op(b, spv::Op::OpBitcast, i, {op(b, spv::Op::OpISub, u, {tableWord(b, entry, footprint::kLayers),
                                                                             constantU32(1)})});
  uint32_t ul = op(b, spv::Op::OpBitcast, u, {ext(b, i, SClamp, {layer, constantI32(0), lastLayer})});
  g.first = op(b, spv::Op::OpIMul, u, {ul, tableWord(b, entry, footprint::kLayerBlocks)});
  g.first = op(b, spv::Op::OpIAdd, u, {g.first, tableWordAt(b, entry, footprint::kLevelStart, level)});
  g.cap = tableWord(b, entry, footprint::kCapacity);
  g.base = tableWord(b, entry, footprint::kBase);
  return g;
}

uint32_t Injector::blockOf(Body& b, const LevelBlocks& g, uint32_t x, uint32_t y) {
  uint32_t u = tU32(), bo = tBool();
  uint32_t ux = op(b, spv::Op::OpBitcast, u, {x}), uy = op(b, spv::Op::OpBitcast, u, {y});
  uint32_t inside = op(b, spv::Op::OpLogicalAnd, bo,
                       {op(b, spv::Op::OpULessThan, bo, {ux, g.width}), op(b, spv::Op::OpULessThan, bo, {uy, g.height})});
  uint32_t row = op(b, spv::Op::OpIMul, u, {op(b, spv::Op::OpShiftRightLogical, u, {uy, g.shiftY}), g.tilesX});
  uint32_t block = op(b, spv::Op::OpIAdd, u, {g.first, op(b, spv::Op::OpIAdd, u, {row, op(b, spv::Op::OpShiftRightLogical, u, {ux, g.shiftX})})});
  return op(b, spv::Op::OpSelect, u, {inside, block, g.cap});
}

// tally_fp_texel_level(entry, x, y, layer, imageLevel): one texel of an
// Image entry; coordinates outside the level mark nothing.
uint32_t Injector::fpTexelLevelFn(FpCombine combine) {
  uint32_t& cached = fpTexelLevels_[static_cast<int>(combine)];
  if (cached != 0) return cached;
  uint32_t u = tU32(), i = tI32();
  auto f = beginFunction({u, i, i, i, u});
  Body b{f->fn.insts};
  uint32_t entry = f->params[0];
  uint32_t level = ext(b, u, UMin, {f->params[4], constantU32(footprint::kMaxLevels - 1)});
  LevelBlocks g = levelBlocks(b, entry, level, f->params[3]);
  fnCall(b, fpMarkFn(combine, (options_.study & kStudyFpRed) != 0), {g.base, g.cap, blockOf(b, g, f->params[1], f->params[2])});
  cached = endFunction(std::move(f), "tally_fp_texel_level");
  return cached;
}

// tally_fp_texel(entry, x, y, layer, lod): a texel at level `lod` of the
// bound view (fetches, storage images, attachments).
uint32_t Injector::fpTexelFn(FpMarkKind markKind) {
  const FpCombine combine = fpCombine(markKind);
  uint32_t& cached = fpTexels_[static_cast<int>(combine)];
  if (cached != 0) return cached;
  uint32_t u = tU32(), i = tI32();
  auto f = beginFunction({u, i, i, i, u});
  Body b{f->fn.insts};
  uint32_t entry = f->params[0];
  uint32_t kind = tableWord(b, entry, footprint::kKind);
  returnIf(b, op(b, spv::Op::OpINotEqual, tBool(), {kind, constantU32(uint32_t(footprint::EntryKind::Image))}));
  uint32_t lastLevel = op(b, spv::Op::OpISub, u, {tableWord(b, entry, footprint::kLevels), constantU32(1)});
  uint32_t level = op(b, spv::Op::OpIAdd, u,
                      {tableWord(b, entry, footprint::kBaseLevel), ext(b, u, UMin, {f->params[4], lastLevel})});
  fnCall(b, fpTexelLevelFn(combine), {entry, f->params[1], f->params[2], f->params[3], level});
  cached = endFunction(std::move(f), "tally_fp_texel");
  return cached;
}

// The texel coordinate after the sampler's address mode; -1 (nothing)
// outside a clamp-to-border image. The mode is the same for every lane (it
// is the bound sampler's), so each mode's arithmetic sits in a branch of its
// own: the integer remainders of the repeating modes cost only where used.
uint32_t Injector::wrap(Body& b, uint32_t c, uint32_t size, uint32_t mode, uint32_t result) {
  uint32_t i = tI32(), bo = tBool();
  uint32_t n = op(b, spv::Op::OpBitcast, i, {size});
  uint32_t last = op(b, spv::Op::OpISub, i, {n, constantI32(1)});
  opNoResult(b, spv::Op::OpStore, {result, ext(b, i, SClamp, {c, constantI32(0), last})});
  auto is = [&](uint32_t m) { return op(b, spv::Op::OpIEqual, bo, {mode, constantU32(m)}); };
  // c mod d (d > 0, the result in [0, d)): a mask where d is a power of two,
  // as texture sizes mostly are, else in unsigned arithmetic (OpSMod gave
  // wrong results for negative c on lavapipe, and OpSRem corrected by d on
  // the H200: the address-mode test at a 12-texel size failed with each).
  auto modulo = [&](Body& t, uint32_t d) {
    uint32_t mask = op(t, spv::Op::OpISub, i, {d, constantI32(1)});
    uint32_t pow2 = op(t, spv::Op::OpIEqual, bo, {op(t, spv::Op::OpBitwiseAnd, i, {d, mask}), constantI32(0)});
    when(t, pow2, [&](Body& y) { opNoResult(y, spv::Op::OpStore, {result, op(y, spv::Op::OpBitwiseAnd, i, {c, mask})}); });
    when(t, op(t, spv::Op::OpLogicalNot, bo, {pow2}),
         [&](Body& y) {
           // In unsigned arithmetic: c mod d for c >= 0, else d - 1 - (-c - 1) mod d.
           uint32_t u = tU32();
           uint32_t negative = op(y, spv::Op::OpSLessThan, bo, {c, constantI32(0)});
           uint32_t magnitude = op(y, spv::Op::OpBitcast, u,
                                   {op(y, spv::Op::OpSelect, i, {negative, op(y, spv::Op::OpISub, i, {constantI32(-1), c}), c})});
           uint32_t ud = op(y, spv::Op::OpBitcast, u, {d});
           uint32_t r = op(y, spv::Op::OpUMod, u, {magnitude, ud});
           r = op(y, spv::Op::OpSelect, u, {negative, op(y, spv::Op::OpISub, u, {op(y, spv::Op::OpISub, u, {ud, constantU32(1)}), r}), r});
           opNoResult(y, spv::Op::OpStore, {result, op(y, spv::Op::OpBitcast, i, {r})});
         });
    return op(t, spv::Op::OpLoad, i, {result});
  };
  when(b, is(footprint::kRepeat), [&](Body& t) { modulo(t, n); });
  when(b, is(footprint::kMirroredRepeat), [&](Body& t) {
    uint32_t twice = op(t, spv::Op::OpIMul, i, {n, constantI32(2)});
    uint32_t m = modulo(t, twice);
    uint32_t mirrored = op(t, spv::Op::OpSelect, i,
                           {op(t, spv::Op::OpSLessThan, bo, {m, n}), m,
                            op(t, spv::Op::OpISub, i, {op(t, spv::Op::OpISub, i, {twice, constantI32(1)}), m})});
    opNoResult(t, spv::Op::OpStore, {result, mirrored});
  });
  when(b, is(footprint::kClampToBorder), [&](Body& t) {
    uint32_t inside = op(t, spv::Op::OpLogicalAnd, bo,
                         {op(t, spv::Op::OpSGreaterThanEqual, bo, {c, constantI32(0)}), op(t, spv::Op::OpSLessThan, bo, {c, n})});
    opNoResult(t, spv::Op::OpStore, {result, op(t, spv::Op::OpSelect, i, {inside, c, constantI32(-1)})});
  });
  when(b, is(footprint::kMirrorClampToEdge), [&](Body& t) {
    uint32_t negative = op(t, spv::Op::OpSLessThan, bo, {c, constantI32(0)});
    uint32_t folded = op(t, spv::Op::OpSelect, i, {negative, op(t, spv::Op::OpISub, i, {constantI32(-1), c}), c});
    opNoResult(t, spv::Op::OpStore, {result, ext(t, i, SClamp, {folded, constantI32(0), last})});
  });
  return op(b, spv::Op::OpLoad, i, {result});
}

// tally_fp_sample_level(entry, imageLevel, u, v, layer, linear, offsetX, offsetY):
// the texels a nearest (1) or bilinear (2 x 2) filter reads at one level.
// The level's geometry is read once; each of the 2 x 2 texels' blocks is
// marked unless one of the others before it is the same block (a bilinear
// footprint mostly lies in one).
uint32_t Injector::fpSampleLevelFn() {
  if (fpSampleLevel_ != 0) return fpSampleLevel_;
  uint32_t u = tU32(), i = tI32(), fl = tF32(), bo = tBool();
  auto f = beginFunction({u, u, fl, fl, i, bo, i, i});
  Body b{f->fn.insts};
  uint32_t wrapped[4];  // the wrapped coordinates, Function variables declared first
  for (uint32_t& v : wrapped) v = functionVariable(b, i);
  uint32_t entry = f->params[0], level = ext(b, u, UMin, {f->params[1], constantU32(footprint::kMaxLevels - 1)});
  uint32_t linear = f->params[5];
  uint32_t sampler = tableWord(b, entry, footprint::kSampler);
  LevelBlocks g = levelBlocks(b, entry, level, f->params[4]);
  auto axis = [&](uint32_t coord, uint32_t size, uint32_t shift, uint32_t offset, const uint32_t* into) {
    uint32_t scaled = op(b, spv::Op::OpFMul, fl, {coord, op(b, spv::Op::OpConvertUToF, fl, {size})});
    scaled = op(b, spv::Op::OpFSub, fl, {scaled, op(b, spv::Op::OpSelect, fl, {linear, constantF32(0.5f), constantF32(0.0f)})});
    uint32_t c0 = op(b, spv::Op::OpIAdd, i, {op(b, spv::Op::OpConvertFToS, i, {ext(b, fl, Floor, {scaled})}), offset});
    uint32_t c1 = op(b, spv::Op::OpIAdd, i, {c0, op(b, spv::Op::OpSelect, i, {linear, constantI32(1), constantI32(0)})});
    uint32_t mode = op(b, spv::Op::OpBitwiseAnd, u,
                       {op(b, spv::Op::OpShiftRightLogical, u, {sampler, constantU32(shift)}), constantU32(7)});
    uint32_t w0 = wrap(b, c0, size, mode, into[0]);
    return std::make_pair(w0, wrap(b, c1, size, mode, into[1]));
  };
  // Not structured bindings: clang before 16 cannot capture them in the lambda below.
  std::pair<uint32_t, uint32_t> xs = axis(f->params[2], g.width, footprint::kAddressUShift, f->params[6], &wrapped[0]);
  std::pair<uint32_t, uint32_t> ys = axis(f->params[3], g.height, footprint::kAddressVShift, f->params[7], &wrapped[2]);
  uint32_t x0 = xs.first, x1 = xs.second, y0 = ys.first, y1 = ys.second;
  uint32_t b00 = blockOf(b, g, x0, y0);
  // A filtered read's blocks are set with the atomic alone: the load that
  // checks the bit first waits on memory at every texel, and on the H200
  // that cost more than the atomics it saved (docs/measurement.md).
  uint32_t mark = fpMarkFn(fpCombine(FpMarkKind::Sample), (options_.study & kStudyFpLoadSamples) == 0);
  fnCall(b, mark, {g.base, g.cap, b00});
  when(b, linear, [&](Body& bb) {
    uint32_t b10 = blockOf(bb, g, x1, y0), b01 = blockOf(bb, g, x0, y1), b11 = blockOf(bb, g, x1, y1);
    auto differs = [&](uint32_t block, std::initializer_list<uint32_t> before) {
      uint32_t all = 0;
      for (uint32_t other : before) {
        uint32_t ne = op(bb, spv::Op::OpINotEqual, bo, {block, other});
        all = all == 0 ? ne : op(bb, spv::Op::OpLogicalAnd, bo, {all, ne});
      }
      return all;
    };
    when(bb, differs(b10, {b00}), [&](Body& t) { fnCall(t, mark, {g.base, g.cap, b10}); });
    when(bb, differs(b01, {b00, b10}), [&](Body& t) { fnCall(t, mark, {g.base, g.cap, b01}); });
    when(bb, differs(b11, {b00, b10, b01}), [&](Body& t) { fnCall(t, mark, {g.base, g.cap, b11}); });
  });
  fpSampleLevel_ = endFunction(std::move(f), "tally_fp_sample_level");
  return fpSampleLevel_;
}

// tally_fp_sample(entry, u, v, layer, lodKind, a, b, offsetX, offsetY):
// a filtered read, Vulkan's level selection (magnification at lambda <= 0;
// nearest level ceil(d + 0.5) - 1, or both linear levels where the
// fraction is non-zero) and filters from the bound sampler.
uint32_t Injector::fpSampleFn() {
  if (fpSample_ != 0) return fpSample_;
  uint32_t u = tU32(), i = tI32(), fl = tF32(), bo = tBool();
  auto f = beginFunction({u, fl, fl, fl, u, fl, fl, i, i});
  Body b{f->fn.insts};
  uint32_t entry = f->params[0], lodKind = f->params[4], a = f->params[5], lam = f->params[6];
  returnIf(b, op(b, spv::Op::OpINotEqual, bo,
                 {tableWord(b, entry, footprint::kKind), constantU32(uint32_t(footprint::EntryKind::Image))}));
  uint32_t sampler = tableWord(b, entry, footprint::kSampler);
  auto bit = [&](uint32_t mask) {
    return op(b, spv::Op::OpINotEqual, bo, {op(b, spv::Op::OpBitwiseAnd, u, {sampler, constantU32(mask)}), constantU32(0)});
  };
  uint32_t levels = tableWord(b, entry, footprint::kLevels);
  uint32_t lastLevel = op(b, spv::Op::OpConvertUToF, fl, {op(b, spv::Op::OpISub, u, {levels, constantU32(1)})});
  uint32_t queried = op(b, spv::Op::OpIEqual, bo, {lodKind, constantU32(uint32_t(Lod::Queried))});
  uint32_t gather = op(b, spv::Op::OpIEqual, bo, {lodKind, constantU32(uint32_t(Lod::Gather))});
  uint32_t lambda = op(b, spv::Op::OpSelect, fl, {queried, lam, a});
  uint32_t d = op(b, spv::Op::OpSelect, fl, {queried, a, ext(b, fl, FClamp, {a, constantF32(0.0f), lastLevel})});
  uint32_t mag = op(b, spv::Op::OpLogicalOr, bo, {gather, op(b, spv::Op::OpFOrdLessThanEqual, bo, {lambda, constantF32(0.0f)})});
  uint32_t linear = op(b, spv::Op::OpLogicalOr, bo, {gather, op(b, spv::Op::OpSelect, bo, {mag, bit(footprint::kMagLinear),
                                                                                          bit(footprint::kMinLinear)})});
  uint32_t mipLinear = bit(footprint::kMipLinear);
  uint32_t dFloor = ext(b, fl, Floor, {d});
  uint32_t nearest = op(b, spv::Op::OpFSub, fl, {ext(b, fl, Ceil, {op(b, spv::Op::OpFAdd, fl, {d, constantF32(0.5f)})}),
                                                constantF32(1.0f)});
  uint32_t l0f = op(b, spv::Op::OpSelect, fl, {mipLinear, dFloor, nearest});
  l0f = op(b, spv::Op::OpSelect, fl, {mag, constantF32(0.0f), l0f});
  l0f = ext(b, fl, FClamp, {l0f, constantF32(0.0f), lastLevel});
  uint32_t fraction = op(b, spv::Op::OpFOrdGreaterThan, bo, {op(b, spv::Op::OpFSub, fl, {d, dFloor}), constantF32(0.0f)});
  uint32_t below = op(b, spv::Op::OpFOrdLessThanEqual, bo, {op(b, spv::Op::OpFAdd, fl, {l0f, constantF32(1.0f)}), lastLevel});
  uint32_t second = op(b, spv::Op::OpLogicalAnd, bo, {op(b, spv::Op::OpLogicalNot, bo, {mag}), mipLinear});
  second = op(b, spv::Op::OpLogicalAnd, bo, {second, op(b, spv::Op::OpLogicalAnd, bo, {fraction, below})});
  uint32_t base = tableWord(b, entry, footprint::kBaseLevel);
  uint32_t level0 = op(b, spv::Op::OpIAdd, u, {base, op(b, spv::Op::OpConvertFToU, u, {l0f})});
  uint32_t lastLayer = op(b, spv::Op::OpBitcast, i, {op(b, spv::Op::OpISub, u, {tableWord(b, entry, footprint::kLayers),
                                                                             constantU32(1)})});
  uint32_t layer = ext(b, i, SClamp, {op(b, spv::Op::OpConvertFToS, i, {ext(b, fl, RoundEven, {f->params[3]})}),
                                      constantI32(0), lastLayer});
  uint32_t levelFn = fpSampleLevelFn();
  fnCall(b, levelFn, {entry, level0, f->params[1], f->params[2], layer, linear, f->params[7], f->params[8]});
  when(b, second, [&](Body& bb) {
    uint32_t level1 = op(bb, spv::Op::OpIAdd, u, {level0, constantU32(1)});
    fnCall(bb, levelFn, {entry, level1, f->params[1], f->params[2], layer, linear, f->params[7], f->params[8]});
  });
  fpSample_ = endFunction(std::move(f), "tally_fp_sample");
  return fpSample_;
}

}  // namespace tally::spirv

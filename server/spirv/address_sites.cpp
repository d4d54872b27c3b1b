// Buffer device addresses: a physical-storage-buffer access counts into the
// slot of the buffer whose address range holds its address. The host's
// table (spirv/address_table.hpp) lists disjoint ranges sorted by start;
// tally_address_slot finds the one before the first that starts above the
// address, as findAddressSlot does on the host, in a function of its own so
// that the search's loop never splits the application's blocks.

#include "spirv/address_table.hpp"
#include "spirv/injector.hpp"

namespace tally::spirv {

uint32_t Injector::dynamicSlots(const FoundSite& s) const {
  if (addressed(s)) return kAddressSlots;
  return s.arrayLength != 0 ? s.arrayLength : kRuntimeArraySlots;
}

uint32_t Injector::slotIndex(Body& b, const FoundSite& s, uint32_t length) {
  if (!addressed(s)) return clampedIndex(b, s, length);
  uint32_t address = op(b, spv::Op::OpConvertPtrToU, tU64(), {s.address});
  return op(b, spv::Op::OpFunctionCall, tU32(), {addressSlotFn(), address});
}

void Injector::declareAddressTable() {
  addCapability(spv::Capability::Int64);
  uint32_t word = tU64();
  uint32_t array = m_.newId();
  newGlobals_.emplace_back(spv::Op::OpTypeRuntimeArray, std::vector<uint32_t>{array, word});
  decorate(array, spv::Decoration::ArrayStride, {8u});
  uint32_t block = m_.newId();
  newGlobals_.emplace_back(spv::Op::OpTypeStruct, std::vector<uint32_t>{block, array});
  const bool storageBuffer = storageClass_ == spv::StorageClass::StorageBuffer;
  decorate(block, storageBuffer ? spv::Decoration::Block : spv::Decoration::BufferBlock);
  newAnnotations_.emplace_back(
      spv::Op::OpMemberDecorate,
      std::vector<uint32_t>{block, 0, static_cast<uint32_t>(spv::Decoration::Offset), 0});
  // Read only: no stage needs stores for it.
  newAnnotations_.emplace_back(
      spv::Op::OpMemberDecorate,
      std::vector<uint32_t>{block, 0, static_cast<uint32_t>(spv::Decoration::NonWritable)});
  addressTable_ = m_.newId();
  newGlobals_.emplace_back(
      spv::Op::OpVariable,
      std::vector<uint32_t>{tPtr(storageClass_, block), addressTable_, static_cast<uint32_t>(storageClass_)});
  decorate(addressTable_, spv::Decoration::DescriptorSet, {options_.set});
  decorate(addressTable_, spv::Decoration::Binding, {options_.addressTableBinding});
  name(block, "TallyAddresses");
  name(addressTable_, "tally_addresses");
  addressWordPtr_ = tPtr(storageClass_, word);
}

uint32_t Injector::addressSlotFn() {
  if (addressSlot_ != 0) return addressSlot_;
  const uint32_t u = tU32(), u64 = tU64(), boolean = tBool();
  uint32_t fnType = type(spv::Op::OpTypeFunction, {u, u64});
  Function fn;
  Body b{fn.insts};
  uint32_t id = m_.newId(), address = m_.newId();
  b.insts.emplace_back(spv::Op::OpFunction, std::vector<uint32_t>{u, id, 0, fnType});
  b.insts.emplace_back(spv::Op::OpFunctionParameter, std::vector<uint32_t>{u64, address});
  label(b, m_.newId());
  const uint32_t varType = tPtr(spv::StorageClass::Function, u);
  uint32_t lo = m_.newId(), hi = m_.newId();
  for (uint32_t var : {lo, hi}) {
    b.insts.emplace_back(
        spv::Op::OpVariable,
        std::vector<uint32_t>{varType, var, static_cast<uint32_t>(spv::StorageClass::Function)});
  }
  const uint32_t zero = constantU32(0), one = constantU32(1), stride = constantU32(kAddressWordsPerSegment);
  auto word = [&](Body& bb, uint32_t index) {
    return op(bb, spv::Op::OpLoad, u64,
              {op(bb, spv::Op::OpAccessChain, addressWordPtr_, {addressTable_, zero, index})});
  };
  // The count, within the table's capacity (a table is never longer).
  uint32_t count = op(b, spv::Op::OpUConvert, u, {word(b, zero)});
  uint32_t capacity = constantU32(kAddressSegments);
  count =
      op(b, spv::Op::OpSelect, u, {op(b, spv::Op::OpULessThan, boolean, {count, capacity}), count, capacity});
  opNoResult(b, spv::Op::OpStore, {lo, zero});
  opNoResult(b, spv::Op::OpStore, {hi, count});
  uint32_t l = 0, h = 0;
  whileLoop(
      b,
      [&](Body& bb) {
        l = op(bb, spv::Op::OpLoad, u, {lo});
        h = op(bb, spv::Op::OpLoad, u, {hi});
        return op(bb, spv::Op::OpULessThan, boolean, {l, h});
      },
      [&](Body& bb) {
        uint32_t mid = op(bb, spv::Op::OpShiftRightLogical, u, {op(bb, spv::Op::OpIAdd, u, {l, h}), one});
        uint32_t start = word(bb, op(bb, spv::Op::OpIAdd, u, {op(bb, spv::Op::OpIMul, u, {mid, stride}), one}));
        uint32_t below = op(bb, spv::Op::OpULessThanEqual, boolean, {start, address});
        opNoResult(bb, spv::Op::OpStore,
                   {lo, op(bb, spv::Op::OpSelect, u, {below, op(bb, spv::Op::OpIAdd, u, {mid, one}), l})});
        opNoResult(bb, spv::Op::OpStore, {hi, op(bb, spv::Op::OpSelect, u, {below, h, mid})});
      },
      [](Body&) {});
  // The segment before `lo` holds the address if any does.
  uint32_t after = op(b, spv::Op::OpLoad, u, {lo});
  uint32_t any = op(b, spv::Op::OpUGreaterThan, boolean, {after, zero});
  uint32_t segment = op(b, spv::Op::OpSelect, u, {any, op(b, spv::Op::OpISub, u, {after, one}), zero});
  uint32_t at = op(b, spv::Op::OpIAdd, u, {op(b, spv::Op::OpIMul, u, {segment, stride}), one});
  uint32_t end = word(b, op(b, spv::Op::OpIAdd, u, {at, one}));
  uint32_t slot = op(b, spv::Op::OpUConvert, u, {word(b, op(b, spv::Op::OpIAdd, u, {at, constantU32(2)}))});
  uint32_t inside =
      op(b, spv::Op::OpLogicalAnd, boolean, {any, op(b, spv::Op::OpULessThan, boolean, {address, end})});
  inside = op(b, spv::Op::OpLogicalAnd, boolean,
              {inside, op(b, spv::Op::OpULessThan, boolean, {slot, constantU32(kAddressSlots)})});
  uint32_t result = op(b, spv::Op::OpSelect, u, {inside, slot, constantU32(kAddressUnknownSlot)});
  opNoResult(b, spv::Op::OpReturnValue, {result});
  b.insts.emplace_back(spv::Op::OpFunctionEnd, std::vector<uint32_t>{});
  name(id, "tally_address_slot");
  newFunctions_.push_back(std::move(fn));
  addressSlot_ = id;
  return id;
}

}  // namespace tally::spirv

// The address table a physical-storage-buffer access searches
// (InstrumentOptions::addressTable, docs/measurement.md "Buffer device
// addresses"): the address ranges of the buffers the host knows, disjoint
// and sorted, each with the counter slot (relative to the site's first) its
// bytes go to. The host builds it (buildAddressTable) and uploads its words;
// the instrumented access finds its slot by binary search, as
// findAddressSlot does on the host.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace tally::spirv {

// A site counted by address has kAddressSlots slots: the address in no
// known range, a known buffer beyond the first kAddressBuffers the host
// gave slots of their own, then one slot per such buffer.
constexpr uint32_t kAddressUnknownSlot = 0;
constexpr uint32_t kAddressOtherSlot = 1;
// Buffers with a line of their own per site: 64 x 8 bytes of counters per
// width of access in each counter region (a few KiB per draw that reads by
// address), against a few tens of buffers reached by address in the
// applications that use them (scene buffers, per-frame uploads).
constexpr uint32_t kAddressBuffers = 64;
constexpr uint32_t kAddressSlots = kAddressBuffers + 2;
constexpr uint32_t kAddressFirstBufferSlot = 2;

// Segments the table holds: 96 KiB in 64-bit words. Ranges beyond it are
// left out (their accesses count as unknown) and the host says so.
constexpr uint32_t kAddressSegments = 4096;
// Layout, in 64-bit words: [0] the segment count, then per segment its
// start, its end (exclusive) and its slot.
constexpr uint32_t kAddressWordsPerSegment = 3;
constexpr size_t addressTableBytes(uint32_t segments) {
  return 8 * (1 + size_t(kAddressWordsPerSegment) * segments);
}

struct AddressRange {
  uint64_t start = 0, end = 0;  // [start, end)
  uint32_t slot = kAddressUnknownSlot;
};

struct AddressTable {
  std::vector<uint64_t> words;
  uint32_t segments = 0;
  uint32_t dropped = 0;  // ranges (or parts) beyond the capacity
};

// The table of `ranges`, given in the order the host learnt them. Where
// ranges overlap (buffers aliasing one memory), an address goes to the
// range that starts lowest, and of ranges that start together to the one
// learnt first: each range keeps only what no earlier one covers.
AddressTable buildAddressTable(std::span<const AddressRange> ranges, uint32_t capacity = kAddressSegments);

// The slot of `address` in a table's words, as the instrumented access finds it.
uint32_t findAddressSlot(std::span<const uint64_t> words, uint64_t address);

}  // namespace tally::spirv

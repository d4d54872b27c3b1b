#include "spirv/address_table.hpp"

#include <algorithm>
#include <numeric>

namespace tally::spirv {

AddressTable buildAddressTable(std::span<const AddressRange> ranges, uint32_t capacity) {
  std::vector<size_t> order(ranges.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return ranges[a].start < ranges[b].start; });
  AddressTable table;
  table.words.push_back(0);
  uint64_t covered = 0;  // the end of what earlier ranges cover
  for (size_t i : order) {
    const AddressRange& r = ranges[i];
    const uint64_t start = std::max(r.start, covered);
    if (start >= r.end) continue;  // empty, or wholly inside earlier ranges
    covered = std::max(covered, r.end);
    if (table.segments == capacity) {
      ++table.dropped;
      continue;
    }
    table.words.insert(table.words.end(), {start, r.end, uint64_t{r.slot}});
    ++table.segments;
  }
  table.words[0] = table.segments;
  return table;
}

uint32_t findAddressSlot(std::span<const uint64_t> words, uint64_t address) {
  if (words.empty()) return kAddressUnknownSlot;
  const uint64_t fit = (words.size() - 1) / kAddressWordsPerSegment;
  const uint64_t n = std::min<uint64_t>(words[0], fit);
  // The first segment that starts after the address; the one before it may hold it.
  uint64_t lo = 0, hi = n;
  while (lo < hi) {
    const uint64_t mid = (lo + hi) / 2;
    if (words[1 + kAddressWordsPerSegment * mid] <= address) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  if (lo == 0) return kAddressUnknownSlot;
  const size_t at = 1 + kAddressWordsPerSegment * (lo - 1);
  if (address >= words[at + 1]) return kAddressUnknownSlot;
  return words[at + 2] < kAddressSlots ? uint32_t(words[at + 2]) : kAddressUnknownSlot;
}

}  // namespace tally::spirv

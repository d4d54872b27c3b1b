// Buffer device addresses: the host's address table (ranges flattened,
// searched as the instrumented access searches it) and the instrumentation
// of physical-storage-buffer accesses that count by address. Expected slots
// are worked out by hand from the ranges.
#include <algorithm>
#include <set>
#include <vector>

#include "spirv/address_table.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::compileGlsl;
using test::disassemble;
using test::instrumentOk;

constexpr uint32_t kA = kAddressFirstBufferSlot, kB = kAddressFirstBufferSlot + 1,
                   kC = kAddressFirstBufferSlot + 2;

TEST(AddressTable, DisjointRangesFindTheirBufferAndGapsAreUnknown) {
  // Learnt out of address order: the table sorts them.
  const std::vector<AddressRange> ranges = {{0x3000, 0x3100, kC}, {0x1000, 0x1400, kA}, {0x2000, 0x2010, kB}};
  auto table = buildAddressTable(ranges);
  ASSERT_EQ(table.segments, 3u);
  EXPECT_EQ(table.words[0], 3u);
  EXPECT_EQ(table.words[1], 0x1000u);  // sorted by start
  EXPECT_EQ(findAddressSlot(table.words, 0x1000), kA);
  EXPECT_EQ(findAddressSlot(table.words, 0x1200), kA);  // the middle of a buffer
  EXPECT_EQ(findAddressSlot(table.words, 0x13ff), kA);
  EXPECT_EQ(findAddressSlot(table.words, 0x1400), kAddressUnknownSlot);  // one past the end
  EXPECT_EQ(findAddressSlot(table.words, 0x2008), kB);
  EXPECT_EQ(findAddressSlot(table.words, 0x30ff), kC);
  EXPECT_EQ(findAddressSlot(table.words, 0x0fff), kAddressUnknownSlot);  // below every range
  EXPECT_EQ(findAddressSlot(table.words, 0x1800), kAddressUnknownSlot);  // between ranges
  EXPECT_EQ(findAddressSlot(table.words, 0x9000), kAddressUnknownSlot);  // above every range
}

TEST(AddressTable, AnEmptyTableKnowsNoAddress) {
  auto table = buildAddressTable({});
  EXPECT_EQ(table.words, std::vector<uint64_t>{0});
  EXPECT_EQ(findAddressSlot(table.words, 0), kAddressUnknownSlot);
  EXPECT_EQ(findAddressSlot(table.words, 0x1000), kAddressUnknownSlot);
}

TEST(AddressTable, AliasedRangesGoToTheLowestStartThenTheFirstLearnt) {
  // A [0x1000, 0x2000); B [0x1800, 0x2800) overlaps its end; C [0x1100,
  // 0x1200) lies inside A; D starts with A, learnt after it.
  const std::vector<AddressRange> ranges = {
      {0x1000, 0x2000, kA}, {0x1800, 0x2800, kB}, {0x1100, 0x1200, kC}, {0x1000, 0x1010, kAddressOtherSlot}};
  auto table = buildAddressTable(ranges);
  EXPECT_EQ(table.segments, 2u);  // A whole, then what of B lies past A; C and D add nothing
  EXPECT_EQ(findAddressSlot(table.words, 0x1000), kA);
  EXPECT_EQ(findAddressSlot(table.words, 0x1150), kA);
  EXPECT_EQ(findAddressSlot(table.words, 0x1900), kA);
  EXPECT_EQ(findAddressSlot(table.words, 0x2000), kB);
  EXPECT_EQ(findAddressSlot(table.words, 0x27ff), kB);
  EXPECT_EQ(findAddressSlot(table.words, 0x2800), kAddressUnknownSlot);
}

TEST(AddressTable, RangesBeyondTheCapacityAreDroppedAndSaidSo) {
  std::vector<AddressRange> ranges;
  for (uint64_t i = 0; i < 5; ++i) ranges.push_back({0x1000 * (i + 1), 0x1000 * (i + 1) + 0x100, kA});
  auto table = buildAddressTable(ranges, 3);
  EXPECT_EQ(table.segments, 3u);
  EXPECT_EQ(table.dropped, 2u);
  EXPECT_EQ(findAddressSlot(table.words, 0x3010), kA);
  EXPECT_EQ(findAddressSlot(table.words, 0x4010), kAddressUnknownSlot);
}

TEST(AddressTable, ASlotOutsideTheSiteCountsAsUnknown) {
  const std::vector<uint64_t> words = {1, 0x1000, 0x2000, kAddressSlots};
  EXPECT_EQ(findAddressSlot(words, 0x1800), kAddressUnknownSlot);
}

const char* kByAddress = R"(#version 460
#extension GL_EXT_buffer_reference : require
layout(local_size_x = 64) in;
layout(buffer_reference, std430, buffer_reference_align = 16) buffer Vectors { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer Words { uint w[]; };
layout(push_constant) uniform Push { Vectors a; Words b; } pc;
void main() {
  uint i = gl_GlobalInvocationID.x;
  pc.a.v[i] = pc.a.v[i + 1u] * 2.0;
  pc.b.w[i] += 1u;
}
)";

TEST(AddressInstrument, PhysicalAccessesCountIntoTheSlotTheirAddressFinds) {
  InstrumentOptions options;
  options.addressTable = true;
  options.addressTableBinding = 3;
  auto r = instrumentOk(compileGlsl(kByAddress, Stage::Compute), options);
  std::string dis = disassemble(r.words);
  EXPECT_NE(dis.find("OpDecorate %tally_addresses Binding 3"), std::string::npos) << dis;
  EXPECT_NE(dis.find("OpDecorate %tally_addresses DescriptorSet 7"), std::string::npos);
  EXPECT_NE(dis.find("OpConvertPtrToU %ulong"), std::string::npos);
  EXPECT_NE(dis.find("OpFunctionCall %uint %tally_address_slot"), std::string::npos);
  auto ep = dis.substr(dis.find("OpEntryPoint"));
  EXPECT_NE(ep.substr(0, ep.find('\n')).find("%tally_addresses"), std::string::npos);
  // Reads and writes of 16 and of 4 bytes: four keys, each with its slots.
  std::set<uint32_t> firsts;
  uint32_t physical = 0;
  for (const auto& s : r.sites) {
    if (s.kind != SiteKind::BufferRead && s.kind != SiteKind::BufferWrite) continue;
    ++physical;
    EXPECT_TRUE(s.byAddress);
    EXPECT_EQ(s.slotCount, kAddressSlots);
    EXPECT_EQ(s.resource, "physical_storage_buffer");
    firsts.insert(s.slot);
  }
  EXPECT_EQ(physical, 4u);
  EXPECT_EQ(firsts.size(), 4u);
  EXPECT_EQ(r.slotCount, 1 + 4 * kAddressSlots);  // the invocation counter and four keys
}

TEST(AddressInstrument, AccumulateModeCountsThemPerAccessAndSaysSo) {
  InstrumentOptions options;
  options.addressTable = true;
  options.mode.kind = CountMode::Accumulate;
  auto r = instrumentOk(compileGlsl(kByAddress, Stage::Compute), options);
  EXPECT_TRUE(std::any_of(r.notes.begin(), r.notes.end(), [](const std::string& n) {
    return n.find("buffer device address accesses (a slot per buffer) are counted per access") !=
           std::string::npos;
  }));
  EXPECT_NE(disassemble(r.words).find("%tally_address_slot"), std::string::npos);
}

TEST(AddressInstrument, WithoutATableTheyShareOneSlotPerWidth) {
  auto r = instrumentOk(compileGlsl(kByAddress, Stage::Compute));
  for (const auto& s : r.sites) {
    EXPECT_FALSE(s.byAddress);
    EXPECT_EQ(s.slotCount, 1u);
  }
  EXPECT_EQ(disassemble(r.words).find("tally_addresses"), std::string::npos);
}

TEST(AddressInstrument, AModuleUsingTheTableBindingIsRefused) {
  const char* taken = R"(#version 450
layout(local_size_x = 1) in;
layout(std430, set = 7, binding = 3) buffer Mine { uint v[]; };
void main() { v[0] = 1u; }
)";
  InstrumentOptions options;
  options.addressTable = true;
  auto r = instrument(compileGlsl(taken, Stage::Compute), options);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("descriptor set 7 binding 3, which the address table lookups need"),
            std::string::npos)
      << r.error();
}

}  // namespace
}  // namespace tally::spirv

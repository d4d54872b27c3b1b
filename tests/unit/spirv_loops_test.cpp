// Sites in loops, in the accumulate mode: which loops get a trip counter,
// which are counted at their entry, and what the reader is told to derive
// (spirv/loops.hpp, accumulate_loops.cpp). Their counts are checked on a
// device in tests/integration/accumulate_loops_test.cpp.
#include <string>

#include "spirv/loops.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::compileGlsl;
using test::disassemble;
using test::instrumentOk;

InstrumentOptions accumulate() {
  InstrumentOptions o;
  o.mode = *parseMode("accumulate:subgroup");
  return o;
}

// The note on loops, or "" where there is none.
std::string loopNote(const Instrumented& r) {
  for (const auto& n : r.notes) {
    if (n.find("in loops derived from") != std::string::npos) return n;
  }
  return "";
}

std::string computeShader(const std::string& body) {
  return R"(#version 450
layout(local_size_x = 8) in;
layout(set = 0, binding = 0) readonly buffer In { uint v[]; } a;
layout(set = 0, binding = 1) readonly buffer More { uint v[]; } b;
layout(set = 0, binding = 2) buffer Out { uint v[]; } o;
layout(set = 0, binding = 3) uniform Params { uint count; int first; } params;
layout(push_constant) uniform Push { uint count; } push;
void main() {
  uint id = gl_GlobalInvocationID.x;
  uint s = 0u;
)" + body + R"(
  o.v[id] = s;
}
)";
}

Instrumented instrumentCompute(const std::string& body, InstrumentOptions options = accumulate()) {
  return instrumentOk(compileGlsl(computeShader(body), Stage::Compute), options);
}

// The derived counts from slot `from`.
std::vector<DerivedCount> derivedFrom(const Instrumented& r, uint32_t from) {
  std::vector<DerivedCount> out;
  for (const auto& d : r.derived) {
    if (d.from == from) out.push_back(d);
  }
  return out;
}

TEST(Loops, ACountedLoopAddsItsTripCountOnceAtItsEntry) {
  for (const char* bound : {"push.count", "params.count"}) {
    auto r = instrumentCompute(std::string("for (uint i = 0u; i < ") + bound + "; ++i) s += a.v[i] + b.v[i];");
    EXPECT_EQ(loopNote(r), "accumulate mode: 2 compute sites in loops derived from 1 trip counter (1 added once where "
                           "the loop is entered)")
        << bound;
    // The trip slot is the last, and no site has it.
    const uint32_t trip = r.firstSlot + r.slotCount - 1;
    for (const auto& s : r.sites) EXPECT_NE(s.slot, trip) << bound;
    EXPECT_EQ(derivedFrom(r, trip).size(), 2u) << bound;
    // Nothing is added inside the loop: the only register adds are the trip
    // count's (and the stores of the flush's zeroes).
    std::string dis = disassemble(r.words);
    EXPECT_NE(dis.find("OpSelect %uint"), std::string::npos) << bound << dis;
  }
}

TEST(Loops, AConstantTripCountAtAnEntryThatRunsOnceIsDerivedFromTheInvocationCount) {
  auto r = instrumentCompute("for (uint i = 0u; i < 8u; ++i) s += a.v[i] + b.v[i];");
  EXPECT_EQ(loopNote(r), "accumulate mode: 2 compute sites in loops derived from 1 trip counter (1 added once where "
                         "the loop is entered, 1 of those adds derived from an enclosing count)");
  auto invocation = test::sitesOf(r, SiteKind::Invocation);
  ASSERT_EQ(invocation.size(), 1u);
  const uint32_t trip = r.firstSlot + r.slotCount - 1;
  ASSERT_FALSE(r.derived.empty());
  EXPECT_EQ(r.derived[0], (DerivedCount{invocation[0]->slot, trip, 8}));
  // No code for the loop at all: no trip register.
  EXPECT_EQ(disassemble(r.words).find("tally_acc_" + std::to_string(trip)), std::string::npos);
}

TEST(Loops, AConstantInnerLoopIsDerivedFromItsOuterLoopsCounter) {
  auto r = instrumentCompute(
      "for (uint i = 0u; i < push.count; ++i) { s += a.v[i]; for (uint j = 0u; j < 4u; ++j) s += b.v[j] + a.v[i + j]; }");
  EXPECT_EQ(loopNote(r), "accumulate mode: 3 compute sites in loops derived from 2 trip counters (2 added once where "
                         "the loop is entered, 1 of those adds derived from an enclosing count)");
  // Settled: 3 outer iterations give a 3 + 3 x 4 x 1, b 3 x 4, whatever order the list is in.
  auto reads = test::sitesOf(r, SiteKind::BufferRead);
  ASSERT_EQ(reads.size(), 3u);
  const uint32_t outer = r.firstSlot + r.slotCount - 2;
  std::vector<uint64_t> counters(r.slotCount, 0);
  counters[outer] = 3;
  settleCounters(counters, r.layout());
  uint64_t a = 0, b = 0;
  for (const Site* s : reads) (s->resource == "a" ? a : b) = counters[s->slot];
  EXPECT_EQ(a, 3u + 12u);
  EXPECT_EQ(b, 12u);
}

TEST(Loops, SitesOfOneIterationShareOneCounterWhereTheTripIsNotKnown) {
  // A data-dependent exit: a counter per iteration, counted inside.
  auto r = instrumentCompute("for (uint k = id; k > 0u; k >>= 1) s += a.v[k] + b.v[k] + a.v[k + 1u];");
  EXPECT_EQ(loopNote(r), "accumulate mode: 3 compute sites in loops derived from 1 trip counter (0 added once where "
                         "the loop is entered)");
  const uint32_t trip = r.firstSlot + r.slotCount - 1;
  auto derived = derivedFrom(r, trip);
  ASSERT_EQ(derived.size(), 2u);  // a's two loads share a slot: times 2
  EXPECT_EQ(derived[0].times + derived[1].times, 3u);
}

TEST(Loops, WhatIsNotCountedAtTheEntry) {
  const char* cases[] = {
      // A break: the header's test is not the only exit.
      "for (uint i = 0u; i < 8u; ++i) { s += a.v[i] + b.v[i]; if (s > 5u) break; }",
      // A bound in a buffer the loop may write.
      "for (uint i = 0u; i < o.v[0]; ++i) { s += a.v[i] + b.v[i]; }",
      // A bound the loop changes.
      "uint n = push.count; for (uint i = 0u; i < n; ++i) { s += a.v[i] + b.v[i]; n = n - (s & 1u); }",
      // A step that is not a constant.
      "for (uint i = 1u; i < 64u; i *= 2u) { s += a.v[i] + b.v[i]; }",
      // Up, but compared with >: ends only by wrapping around.
      "for (uint i = 9u; i > 3u; ++i) { s += a.v[i] + b.v[i]; }",
      // != with a step of 2 may never meet its bound.
      "for (uint i = 0u; i != push.count; i += 2u) { s += a.v[i] + b.v[i]; }",
      // A do-while: the test is at the end.
      "uint i = 0u; do { s += a.v[i] + b.v[i]; ++i; } while (i < push.count);",
  };
  for (const char* body : cases) {
    auto r = instrumentCompute(body);
    EXPECT_NE(loopNote(r).find("(0 added once"), std::string::npos) << body << ": " << loopNote(r);
  }
}

TEST(Loops, OneSiteWithoutAKnownTripKeepsItsOwnAdd) {
  auto r = instrumentCompute("for (uint k = id; k > 0u; k >>= 1) s += a.v[k];");
  EXPECT_EQ(loopNote(r), "");
  auto reads = test::sitesOf(r, SiteKind::BufferRead);
  ASSERT_EQ(reads.size(), 1u);
  for (const auto& d : r.derived) EXPECT_NE(d.to, reads[0]->slot);
}

TEST(Loops, NestedLoopsCountEachLoopApart) {
  auto r = instrumentCompute(
      "for (uint i = 0u; i < push.count; ++i) { s += a.v[i]; for (uint j = 0u; j < i; ++j) s += b.v[j] + a.v[i + j]; }");
  EXPECT_EQ(loopNote(r), "accumulate mode: 3 compute sites in loops derived from 2 trip counters (2 added once where "
                         "the loop is entered)");
}

// Optimised SPIR-V (what applications hand the layer): the induction
// variable is an OpPhi of the header, here stepped by 3 up to a push constant.
std::string phiLoop(const std::string& compare) {
  return R"(OpCapability Shader
OpMemoryModel Logical GLSL450
OpEntryPoint GLCompute %main "main" %in %pc
OpExecutionMode %main LocalSize 8 1 1
OpDecorate %arr ArrayStride 4
OpMemberDecorate %In 0 Offset 0
OpDecorate %In Block
OpDecorate %in DescriptorSet 0
OpDecorate %in Binding 0
OpMemberDecorate %Push 0 Offset 0
OpDecorate %Push Block
%void = OpTypeVoid
%fn = OpTypeFunction %void
%uint = OpTypeInt 32 0
%int = OpTypeInt 32 1
%bool = OpTypeBool
%arr = OpTypeRuntimeArray %uint
%In = OpTypeStruct %arr
%ptr_sb = OpTypePointer StorageBuffer %In
%in = OpVariable %ptr_sb StorageBuffer
%ptr_u = OpTypePointer StorageBuffer %uint
%Push = OpTypeStruct %uint
%ptr_pc = OpTypePointer PushConstant %Push
%pc = OpVariable %ptr_pc PushConstant
%ptr_pcu = OpTypePointer PushConstant %uint
%int_0 = OpConstant %int 0
%uint_0 = OpConstant %uint 0
%uint_3 = OpConstant %uint 3
%main = OpFunction %void None %fn
%entry = OpLabel
%pcp = OpAccessChain %ptr_pcu %pc %int_0
%n = OpLoad %uint %pcp
OpBranch %header
%header = OpLabel
%i = OpPhi %uint %uint_0 %entry %next %body
%cond = )" + compare + R"( %bool %i %n
OpLoopMerge %merge %body None
OpBranchConditional %cond %body %merge
%body = OpLabel
%p1 = OpAccessChain %ptr_u %in %int_0 %i
%v1 = OpLoad %uint %p1
%next = OpIAdd %uint %i %uint_3
OpBranch %header
%merge = OpLabel
OpReturn
OpFunctionEnd
)";
}

TEST(Loops, AnOpPhiInductionVariableIsCountedAtTheEntry) {
  auto r = instrumentOk(test::assemble(phiLoop("OpULessThan")), accumulate());
  EXPECT_EQ(loopNote(r), "accumulate mode: 1 compute site in loops derived from 1 trip counter (1 added once where "
                         "the loop is entered)");
  // ceil((n - 0) / 3): the division and its remainder.
  std::string dis = disassemble(r.words);
  EXPECT_NE(dis.find("OpUDiv %uint"), std::string::npos) << dis;
  EXPECT_NE(dis.find("OpUMod %uint"), std::string::npos) << dis;
  // != with a step of 3 might never meet the bound: one site, no counter.
  auto unequal = instrumentOk(test::assemble(phiLoop("OpINotEqual")), accumulate());
  EXPECT_EQ(loopNote(unequal), "");
  EXPECT_TRUE(unequal.derived.empty());
}

TEST(Loops, OffWhereSitesAreNotDerived) {
  auto options = accumulate();
  options.deriveOnceSites = false;
  auto r = instrumentCompute("for (uint i = 0u; i < 8u; ++i) s += a.v[i] + b.v[i];", options);
  EXPECT_EQ(loopNote(r), "");
  EXPECT_TRUE(r.derived.empty());
}

// The analysis itself, on the loop of a fragment shader that may demote:
// the blocks before the demote form a class; the ones after it run less
// often; the loop is not counted at its entry.
TEST(Loops, ClassesStopWhereTheInvocationMayEnd) {
  const char* source = R"(#version 450
#extension GL_EXT_demote_to_helper_invocation : require
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() {
  vec4 c = vec4(0.0);
  for (int i = 0; i < 4; ++i) {
    c += texture(tex, uv * float(i));
    if (c.x > 0.5) demote;
    c += texture(tex, uv + float(i));
  }
  color = c;
}
)";
  auto words = compileGlsl(source, Stage::Fragment);
  auto m = Module::parse(words);
  ASSERT_TRUE(m.ok()) << m.error();
  DefIndex defs(*m);
  FunctionLoops fl = findLoops(*m, defs, 0);
  ASSERT_EQ(fl.loops.size(), 1u);
  const Loop& loop = fl.loops[0];
  EXPECT_FALSE(loop.counted.has_value());
  EXPECT_EQ(loop.everyIteration, -1);
  // Each sample's block: the first before the demote, the second after it, in classes apart.
  std::vector<int> blocks;
  const auto& insts = m->functions[0].insts;
  for (size_t i = 0; i < insts.size(); ++i) {
    if (insts[i].opcode() == spv::Op::OpImageSampleImplicitLod) blocks.push_back(fl.blockAt[i]);
  }
  ASSERT_EQ(blocks.size(), 2u);
  EXPECT_GE(loop.classOf[blocks[0]], 0);
  EXPECT_GE(loop.classOf[blocks[1]], 0);
  EXPECT_NE(loop.classOf[blocks[0]], loop.classOf[blocks[1]]);
  EXPECT_NE(loop.classOf[blocks[0]], loop.header);
}

}  // namespace
}  // namespace tally::spirv

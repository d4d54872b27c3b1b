// The static arithmetic count (spirv/arith.hpp) on small shaders whose
// operations are counted here by reading the GLSL: glslang without
// optimisation emits one instruction per operator, calls stay calls.
#include <gtest/gtest.h>

#include "spirv/arith.hpp"
#include "spirv_test_util.hpp"

namespace tally::spirv {
namespace {

using test::compileGlsl;

ArithmeticCount countOf(const std::string& glsl, Stage stage = Stage::Compute) {
  auto words = compileGlsl(glsl, stage);
  auto counted = countArithmetic(words);
  EXPECT_TRUE(counted.ok()) << (counted.ok() ? "" : counted.error());
  if (!counted.ok() || counted->size() != 1) return {};
  EXPECT_EQ((*counted)[0].entryPoint, "main");
  return (*counted)[0].ops;
}

TEST(ArithmeticCount, ComponentWiseFloatAndIntegerOperations) {
  ArithmeticCount c = countOf(R"(#version 460
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 0) buffer B { vec4 a; vec4 b; float s; uint u; uint w; } buf;
void main() {
  vec4 x = buf.a * buf.b;         // OpFMul vec4: 4
  x = x + buf.a;                  // OpFAdd vec4: 4
  x = x * buf.s;                  // OpVectorTimesScalar: 4
  float d = dot(x, buf.b);        // OpDot of 4: 4 multiplies + 3 adds = 7
  buf.s = d - 1.0;                // OpFSub: 1
  buf.u = (buf.u << 2u) + buf.w;  // OpShiftLeftLogical 1 + OpIAdd 1
}
)");
  EXPECT_EQ(c.floatOps, 4u + 4u + 4u + 7u + 1u);
  EXPECT_EQ(c.integerOps, 2u);
  EXPECT_EQ(c.extendedOps, 0u);
  EXPECT_EQ(c.total(), 22u);
}

TEST(ArithmeticCount, ExtendedCallsHelpersPerCallAndLoopsOnce) {
  ArithmeticCount c = countOf(R"(#version 460
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 0) buffer B { vec4 p; int count; float result; } buf;
float helper(vec3 v) { return length(v) * 2.0; }  // length(vec3): 3 extended; OpFMul: 1
void main() {
  vec3 n = normalize(buf.p.xyz);                  // normalize(vec3): 3 extended
  float a = helper(n) + helper(buf.p.xyz);        // two calls: 2 x (3 + 1); OpFAdd: 1
  for (int i = 0; i < buf.count; ++i) {           // ++i: OpIAdd 1 (the comparison counts nothing)
    a = fma(a, 0.5, 1.0);                         // Fma: 2, counted once however many iterations
  }
  buf.result = a;
}
)");
  EXPECT_EQ(c.extendedOps, 3u + 2u * 3u + 2u);
  EXPECT_EQ(c.floatOps, 2u * 1u + 1u);
  EXPECT_EQ(c.integerOps, 1u);
}

TEST(ArithmeticCount, MatrixProductsCountMultipliesAndAdds) {
  ArithmeticCount c = countOf(R"(#version 460
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 0) buffer B { mat4 m; mat3 n; vec4 p; vec3 q; vec4 r; vec3 s; mat4 mm; } buf;
void main() {
  buf.r = buf.m * buf.p;   // OpMatrixTimesVector: 4 rows x (4 multiplies + 3 adds) = 28
  buf.s = buf.q * buf.n;   // OpVectorTimesMatrix: 3 columns x (3 + 2) = 15
  buf.mm = buf.m * buf.m;  // OpMatrixTimesMatrix: 16 results x 7 = 112
}
)");
  EXPECT_EQ(c.floatOps, 28u + 15u + 112u);
  EXPECT_EQ(c.integerOps, 0u);
  EXPECT_EQ(c.extendedOps, 0u);
}

TEST(ArithmeticCount, FragmentShaderIgnoresConversionsAndComparisons) {
  ArithmeticCount c = countOf(R"(#version 460
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() {
  float k = uv.x > 0.5 ? 1.0 : 0.0;        // comparison and select: nothing
  int i = int(uv.y * 8.0);                 // OpFMul 1; the conversion: nothing
  color = vec4(uv * k, float(i), 1.0);     // OpVectorTimesScalar vec2: 2
}
)", Stage::Fragment);
  EXPECT_EQ(c.floatOps, 3u);
  EXPECT_EQ(c.integerOps, 0u);
  EXPECT_EQ(c.extendedOps, 0u);
}

// instrument() reports the count of the module it was given: the counters it
// adds (accumulate mode adds integer adds) are not the shader's arithmetic.
TEST(ArithmeticCount, InstrumentCountsTheInputModule) {
  auto words = compileGlsl(R"(#version 460
layout(local_size_x = 8) in;
layout(std430, set = 0, binding = 0) buffer B { float v[]; } buf;
void main() {
  uint i = gl_GlobalInvocationID.x;
  buf.v[i] = buf.v[i] * 3.0 + 1.0;  // OpFMul 1 + OpFAdd 1
}
)", Stage::Compute);
  InstrumentOptions options;
  options.mode = Mode{CountMode::Accumulate};
  auto instrumented = test::instrumentOk(words, options);
  ASSERT_EQ(instrumented.arithmetic.size(), 1u);
  EXPECT_EQ(instrumented.arithmetic[0].entryPoint, "main");
  EXPECT_EQ(instrumented.arithmetic[0].ops.floatOps, 2u);
  EXPECT_EQ(instrumented.arithmetic[0].ops.integerOps, 0u);
  auto rewritten = countArithmetic(instrumented.words);
  ASSERT_TRUE(rewritten.ok());
  EXPECT_GT((*rewritten)[0].ops.integerOps, 0u);  // the counters' own additions
  EXPECT_EQ((*rewritten)[0].ops.floatOps, 2u);
}

TEST(ArithmeticCount, RejectsWhatIsNotSpirv) {
  std::vector<uint32_t> junk = {1, 2, 3, 4, 5, 6};
  EXPECT_FALSE(countArithmetic(junk).ok());
}

}  // namespace
}  // namespace tally::spirv

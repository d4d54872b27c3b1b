#version 460
// Depth pre-pass, instrumented runs only: an empty fragment stage whose
// invocation counter (with early tests: one per fragment that passes the
// depth test) gives the pass's depth writes. A pipeline without a fragment
// shader has nothing to count, and the fragment-invocation statistic is 0
// there (NVIDIA) or counts rejected fragments too (lavapipe). The
// uninstrumented twin, used for timing, keeps the depth-only pipeline.
#extension GL_GOOGLE_include_directive : require
#ifdef TALLY_ALPHA_TEST
#define TALLY_MATERIALS  // alpha_test.h reads the material
#endif
#ifdef TALLY_ALPHA_TEST
// alphaMode MASK draws (alpha_test.h): the test decides coverage, so no early tests.
#include "common.h"
#include "alpha_test.h"
#else
layout(early_fragment_tests) in;
#endif
#ifdef TALLY_ALPHA_TEST
layout(push_constant) uniform PushBlock { DrawPush push; };
#endif

void main() {
#ifdef TALLY_ALPHA_TEST
  alphaTest(push.materialIndex);
#endif
}

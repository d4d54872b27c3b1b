#version 460
// Depth pre-pass, instrumented runs only: an empty fragment stage whose
// invocation counter (with early tests: one per fragment that passes the
// depth test) gives the pass's depth writes. A pipeline without a fragment
// shader has nothing to count, and the fragment-invocation statistic is 0
// there (NVIDIA) or counts rejected fragments too (lavapipe). The
// uninstrumented twin, used for timing, keeps the depth-only pipeline.
#extension GL_GOOGLE_include_directive : require
#include "alpha_test_stage.h"  // early tests, or the alpha test of MASK draws
#ifdef TALLY_ALPHA_TEST
layout(push_constant) uniform PushBlock { DrawPush push; };
#endif

void main() {
  ALPHA_TEST(push.materialIndex);  // alphaMode MASK draws (alpha_test_stage.h)
}

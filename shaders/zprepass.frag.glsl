#version 460
// Depth pre-pass, instrumented runs only: an empty fragment stage whose
// invocation counter (with early tests: one per fragment that passes the
// depth test) gives the pass's depth writes. A pipeline without a fragment
// shader has nothing to count, and the fragment-invocation statistic is 0
// there (NVIDIA) or counts rejected fragments too (lavapipe). The
// uninstrumented twin, used for timing, keeps the depth-only pipeline.
layout(early_fragment_tests) in;

void main() {}

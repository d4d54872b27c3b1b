// The fragment stages of the passes that otherwise read no material (the
// depth pre-pass, the visibility passes, the shadow pass): early fragment
// tests, or for alphaMode MASK draws (TALLY_ALPHA_TEST) the alpha test of
// alpha_test.h instead, called as ALPHA_TEST(material) at the start of main.
// Include after the shader's own TALLY_* defines, before it includes common.h.
#ifndef TALLY_SHADERS_ALPHA_TEST_STAGE_H
#define TALLY_SHADERS_ALPHA_TEST_STAGE_H
#ifdef TALLY_ALPHA_TEST
#define TALLY_MATERIALS  // the alpha test reads the material
#include "common.h"
#include "alpha_test.h"
#define ALPHA_TEST(material) alphaTest(material)
#else
layout(early_fragment_tests) in;
#define ALPHA_TEST(material)
#endif
#endif  // TALLY_SHADERS_ALPHA_TEST_STAGE_H

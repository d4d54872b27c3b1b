// Vertex side of alpha_test.h: with TALLY_ALPHA_TEST the uvs and colour
// the fragment stage's alpha test needs, at locations 8-10 (clear of every
// pass's own outputs). Define TALLY_HAS_UV_INPUT where the shader already
// reads kAttribUv as inUv.
#ifndef TALLY_SHADERS_ALPHA_TEST_VERT_H
#define TALLY_SHADERS_ALPHA_TEST_VERT_H
#ifdef TALLY_ALPHA_TEST

#ifndef TALLY_HAS_UV_INPUT
layout(location = kAttribUv) in vec2 inUv;
#endif
layout(location = 8) out vec2 alphaUv0;
#ifdef TALLY_UV1
layout(location = kAttribUv1) in vec2 inAlphaUv1;
layout(location = 9) out vec2 alphaUv1;
#endif
#ifdef TALLY_VERTEX_COLORS
layout(location = kAttribColor) in vec4 inAlphaColor;
layout(location = 10) out vec4 alphaColor;
#endif

void passAlphaInputs() {
  alphaUv0 = inUv;
#ifdef TALLY_UV1
  alphaUv1 = inAlphaUv1;
#endif
#ifdef TALLY_VERTEX_COLORS
  alphaColor = inAlphaColor;
#endif
}

#else
void passAlphaInputs() {}
#endif  // TALLY_ALPHA_TEST
#endif  // TALLY_SHADERS_ALPHA_TEST_VERT_H

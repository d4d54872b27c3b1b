#version 460
#extension GL_GOOGLE_include_directive : require
// Forward renderer, geometry pass: world position, TBN frame and uv for forward.frag.
#include "mesh.vert.h"

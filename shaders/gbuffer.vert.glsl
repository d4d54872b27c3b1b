#version 460
#extension GL_GOOGLE_include_directive : require
// Deferred renderer, G-buffer pass: the same vertex work as forward.vert.
#include "mesh.vert.h"

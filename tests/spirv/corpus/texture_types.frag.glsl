#version 450
// Other image dimensions in four descriptor sets: cube, 2D array, 3D, 1D, texel buffer.
layout(set = 0, binding = 4) uniform samplerCube envMap;
layout(set = 1, binding = 4) uniform sampler2DArray atlas;
layout(set = 2, binding = 4) uniform sampler3D lut;
layout(set = 3, binding = 4) uniform sampler1D ramp;
layout(set = 3, binding = 5) uniform samplerBuffer texels;

layout(location = 0) in vec3 inDir;
layout(location = 1) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec4 env = texture(envMap, inDir);
  vec4 tile = texture(atlas, vec3(inUv, 2.0));
  vec4 graded = texture(lut, env.rgb);
  vec4 r = texture(ramp, tile.r);
  vec4 t = texelFetch(texels, int(inUv.x * 64.0));
  outColor = graded * r + t;
}

#version 450
// Compute sampling through nested helper functions, loops and branches.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D source;
layout(set = 0, binding = 1, rgba16f) uniform writeonly image2D destination;
layout(set = 3, binding = 3) uniform Blur {
  int radius;
  float sigma;
} blur;

vec4 fetchTap(sampler2D tex, vec2 uv) {
  return textureLod(tex, uv, 0.0);
}

vec4 gaussian(sampler2D tex, vec2 uv, vec2 texel) {
  vec4 sum = vec4(0.0);
  float total = 0.0;
  for (int x = -blur.radius; x <= blur.radius; ++x) {
    float w = exp(-float(x * x) / (2.0 * blur.sigma * blur.sigma));
    if (w < 0.01) {
      continue;
    }
    sum += fetchTap(tex, uv + vec2(float(x), 0.0) * texel) * w;
    total += w;
  }
  return sum / total;
}

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  vec2 size = vec2(textureSize(source, 0));
  vec2 uv = (vec2(p) + 0.5) / size;
  imageStore(destination, p, gaussian(source, uv, 1.0 / size));
}

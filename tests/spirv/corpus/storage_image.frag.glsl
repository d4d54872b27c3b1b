#version 450
// Fragment storage images: imageLoad (texture_read), imageStore, imageSize (not counted).
layout(set = 2, binding = 0, rgba8) uniform readonly image2D srcImage;
layout(set = 2, binding = 1, rgba16f) uniform writeonly image2D dstImage;

layout(location = 0) out vec4 outColor;

void main() {
  ivec2 size = imageSize(srcImage);
  ivec2 p = ivec2(gl_FragCoord.xy) % size;
  vec4 c = imageLoad(srcImage, p);
  imageStore(dstImage, p, c * 2.0);
  outColor = c;
}

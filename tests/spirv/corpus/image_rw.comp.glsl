#version 450
// Compute storage images: imageLoad (texture_read), imageStore (image_write), imageSize (not counted).
layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 0, binding = 0, rgba8) uniform readonly image2D inputImage;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D outputImage;
layout(set = 3, binding = 2, r32f) uniform image2D accumImage;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  ivec2 size = imageSize(inputImage);
  if (p.x >= size.x || p.y >= size.y) {
    return;
  }
  vec4 c = imageLoad(inputImage, p);
  float acc = imageLoad(accumImage, p).r;
  imageStore(accumImage, p, vec4(acc + c.r));
  imageStore(outputImage, p, c.bgra);
}

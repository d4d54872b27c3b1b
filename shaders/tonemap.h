// Reinhard on luminance, hue kept: the tonemap pass's operator, shared with
// the transparent pass, which blends tonemapped colours into "final".
#ifndef TALLY_SHADERS_TONEMAP_H
#define TALLY_SHADERS_TONEMAP_H
vec3 tonemapReinhard(vec3 hdr, float exposure) {
  hdr *= exposure;
  float luminance = dot(hdr, vec3(0.2126, 0.7152, 0.0722));
  return clamp(hdr * (1.0 / (1.0 + luminance)), 0.0, 1.0);  // L / (1 + L)
}
#endif  // TALLY_SHADERS_TONEMAP_H

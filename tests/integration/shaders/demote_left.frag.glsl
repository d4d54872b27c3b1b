#version 450
#extension GL_EXT_demote_to_helper_invocation : require
// discard_left.frag.glsl with demote (OpDemoteToHelperInvocation) for discard:
// the left columns go on as helper invocations, whose accesses are not
// counted. The counts are the same. From discard_left:
// five_reads with a discard between its reads: every pixel reads albedo and
// detail, then the columns left of x = 100 (pixel centres 0.5 .. 99.5) end
// in OpKill; the rest read mask, albedo and detail again and write the
// output. Counts at W x H (W > 100): albedo and detail W*H + (W-100)*H each,
// mask (W-100)*H, outputs (W-100)*H, invocations W*H.
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform sampler2D detail;
layout(set = 0, binding = 2) uniform sampler2D mask;

layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;

void main() {
  vec4 a = texture(albedo, uv);
  vec4 b = texture(detail, uv * 3.0);
  if (gl_FragCoord.x < 100.0) demote;
  vec4 c = texture(mask, uv + vec2(0.25, 0.5));
  vec4 d = texture(albedo, uv.yx * 2.0);
  vec4 e = texture(detail, uv * 0.5 + 0.125);
  color = a * 0.4 + b * 0.2 + c * 0.2 + d * 0.1 + e * 0.1;
}

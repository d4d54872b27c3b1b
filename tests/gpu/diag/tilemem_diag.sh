#!/usr/bin/env bash
# Diagnosis of the gbuffer=subpass image on one device: for each quantity the
# lighting pass decodes (normal, diffuse, ambient, specular, roughness, depth,
# position), both lighting shaders output it instead of the shading, and the
# subpass image is compared with the sampled one (variant_error). The
# quantity whose images differ is the one read wrongly.
#   tests/gpu/diag/tilemem_diag.sh      (after tests/gpu/build.sh; OUT=dir)
set -uo pipefail
cd "$(dirname "$0")/../../.."
. tests/gpu/env.sh
tally_gpu_script tilemem_diag.sh DIAG_RESOLUTION || exit 2
line='  outColor = vec4(shade(s, worldFromDepth(gl_FragCoord.xy, depth)), 1.0);'
declare -A expr=(
  [normal]='vec4(s.normal * 0.5 + 0.5, 1.0)'
  [diffuse]='vec4(s.diffuse, 1.0)'
  [ambient]='vec4(vec3(s.ambient), 1.0)'
  [specular]='vec4(s.specular, 1.0)'
  [roughness]='vec4(vec3(s.roughness), 1.0)'
  [depth]='vec4(fract(depth * 1000.0), fract(depth * 100000.0), 0.0, 1.0)'
  [position]='vec4(fract(worldFromDepth(gl_FragCoord.xy, depth)), 1.0)'
  [shaded]='vec4(shade(s, worldFromDepth(gl_FragCoord.xy, depth)), 1.0)'
)
cat > "$out/diag-spec.json" <<JSON
{"renderers": [{"renderer": "deferred", "options": {"gbuffer": "subpass"}}], "scenes": ["atrium"],
 "resolutions": [[${width}, ${height}]],
 "cameras": [{"eye": [-9.600, 7.735, -3.000], "target": [-4.345, 12.990, -3.000], "fov_deg": 60}],
 "frames": 1, "lights": 400}
JSON
for q in "${!expr[@]}"; do
  dir="$out/shaders-$q"
  rm -rf "$dir" && cp -r shaders "$dir"
  for f in lighting.frag.glsl lighting_subpass.frag.glsl; do
    python3 - "$dir/$f" "$line" "  outColor = ${expr[$q]};" <<'PY'
import sys
p, old, new = sys.argv[1:4]
s = open(p).read()
assert s.count(old) == 1, p
open(p, "w").write(s.replace(old, new))
PY
  done
  TALLY_SHADER_DIR="$dir" "$tallyd" capture --spec "$out/diag-spec.json" --out "$out/diag-$q.json" 2> "$out/diag-$q.log"
  python3 - "$q" "$out/diag-$q.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[2]))
e = r["runs"][0]["samples"][0].get("variant_error", {})
print(f"{sys.argv[1]:10s} subpass vs sampled: identical={e.get('identical')} psnr={e.get('psnr')} max_abs={e.get('max_abs')} mean_abs={e.get('mean_abs')}")
PY
done

#!/usr/bin/env bash
# A frame's host wall time beside its GPU time, counted and plain, for
# accumulate alone and for accumulate with 64-byte footprint blocks: every
# renderer of counting_cost.sh's Sponza spec at 1920x1080 on one scene, 4
# cameras, each capture against its own uninstrumented frames
# (extras.frame_wall_ms, docs/result-schema.md). Build first with
# tests/gpu/build.sh (tallyd is enough); bring .gl/ (run.sh), and for Sponza
# .scenes/sponza (protocol.sh).
#
#   tests/gpu/diag/frame_wall.sh
#   OUT=dir        results (default ./gpu-out): frame-wall.txt (the tables),
#                  frame-wall.tar.gz (each setting's spec, result, log and table)
#   WALL_SCENE=S   SPONZA (default; its 4 fixed cameras) or a built-in scene
#                  name such as atrium (its 4 automatic cameras)
#   WALL_SETTINGS="accumulate footprint"   which to run (default both)
set -uo pipefail
cd "$(dirname "$0")/../../.."
. tests/gpu/env.sh
WALL_RESOLUTION="${WALL_RESOLUTION:-1920x1080}"
tally_gpu_script frame_wall.sh WALL_RESOLUTION || exit 2
scene="${WALL_SCENE:-SPONZA}"
# Another scene takes its own cameras (tests/gpu/accuracy-<scene>.json), not Sponza's.
base="$out/base-spec.json"
python3 -c 'import json, sys
spec = json.load(open(sys.argv[1]))
if sys.argv[2] != "SPONZA":
    spec.pop("cameras")
print(json.dumps(spec))' tests/gpu/counting/sponza.json "$scene" > "$base" || exit 2
status=0
settings="${WALL_SETTINGS:-accumulate footprint}"
for setting in $settings; do
  footprint=()
  [ "$setting" = footprint ] && footprint=(--footprint 64)
  spec="$out/$setting-spec.json"
  python3 tests/gpu/spec_edit.py "$base" --sponza "$(tally_sponza_path)" --scene "$scene" \
    --cameras 4 --resolution "${width}x${height}" --counting accumulate "${footprint[@]}" > "$spec" || { status=2; continue; }
  tally_timed_capture "frame wall $setting $scene ${width}x${height}" "$spec" "$out/$setting.json" "$out/$setting.log" \
    "$out/frame-wall.txt" || { status=1; continue; }
  rm -rf "$out/$setting-screenshots"
  { echo "== $setting"; python3 tests/gpu/counting_summary.py "$out/$setting.json" | grep -vE "Register Count|^\| renderer \| pass \| stages"; } |
    tee "$out/$setting.md" >> "$out/frame-wall.txt"
done
cat "$out/frame-wall.txt"
tar czf "$out/frame-wall.tar.gz" -C "$out" $(cd "$out" && ls -- *-spec.json *.json *.log *.md 2>/dev/null | sort -u)
exit "$status"

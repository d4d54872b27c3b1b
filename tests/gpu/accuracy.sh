#!/usr/bin/env bash
# Counting modes, speed against accuracy: every renderer in every counting mode
# (exact, subgroup, sampled:4, sampled:16, sampled:64) on atrium and on Sponza,
# at 1280x720, 4 cameras, 10 frames; then `tallyd accuracy` on each result
# (overhead ratio against the uninstrumented frames of the same run, counting
# error against the exact run). Build first with tests/gpu/build.sh; bring the
# Vulkan loader's .debs in .gl/ (see run.sh) and a copy of the Sponza folder in
# .scenes/sponza (as protocol.sh). docs/accuracy.md reports the figures.
#
#   tests/gpu/accuracy.sh
#   OUT=dir                where results go (default ./gpu-out): accuracy-<scene>.json (result),
#                          accuracy-<scene>.txt and .accuracy.json (tallyd accuracy), accuracy-<scene>.log,
#                          accuracy.log (wall times)
#   TALLYD=path            tallyd to run (default build-gpu/server/tallyd)
#   ACCURACY_SCENES="atrium sponza"   which specs to run (tests/gpu/accuracy-<scene>.json)
#   ACCURACY_RESOLUTION=WxH           replaces 1280x720, e.g. 160x90 for a check on lavapipe
#   ACCURACY_FRAMES=N                 replaces the 10 frames per sample
set -uo pipefail
cd "$(dirname "$0")/../.."

# $out, $tallyd, $width and $height; Vulkan on the GPU machine (env.sh).
. tests/gpu/env.sh
tally_gpu_script accuracy.sh ACCURACY_RESOLUTION || exit 2
scenes="${ACCURACY_SCENES:-atrium sponza}"
frames="${ACCURACY_FRAMES:-10}"
sponza="$(tally_sponza_path)"

status=0
for scene in $scenes; do
  spec_in="tests/gpu/accuracy-$scene.json"
  [ -f "$spec_in" ] || { echo "accuracy.sh: no $spec_in" >&2; status=2; continue; }
  spec="$out/accuracy-$scene-spec.json"
  python3 tests/gpu/spec_edit.py "$spec_in" --sponza "$sponza" --resolution "${width}x${height}" \
    --frames "$frames" > "$spec" || { status=2; continue; }
  tally_timed_capture "accuracy $scene ${width}x${height}" "$spec" "$out/accuracy-$scene.json" \
    "$out/accuracy-$scene.log" "$out/accuracy.log" || { status=$?; continue; }
  "$tallyd" accuracy --result "$out/accuracy-$scene.json" > "$out/accuracy-$scene.txt" || status=1
  "$tallyd" accuracy --result "$out/accuracy-$scene.json" --json > "$out/accuracy-$scene.accuracy.json" || status=1
  cat "$out/accuracy-$scene.txt"
done
exit "$status"

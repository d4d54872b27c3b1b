#!/usr/bin/env bash
# Repeatability: the same atrium spec (four renderers, 4 cameras, 20 frames,
# 1280x720, exact counting) captured several times with `tallyd capture`, one
# process per capture; then `tallyd repeats` on the results: per renderer, each
# capture's median frame time, the across-capture median and IQR, the
# within-run noise (median per-sample IQR over the frames), whether every
# capture lies in the band docs/measurement.md ("Repeatability") defines, and
# whether the counts are identical. Build first with tests/gpu/build.sh; bring
# the Vulkan loader's .debs in .gl/ (see run.sh). docs/accuracy.md reports the
# figures.
#
#   tests/gpu/repeats.sh
#   OUT=dir                   where results go (default ./gpu-out): repeats-<i>.json (results),
#                             repeats.txt and repeats.json (tallyd repeats), repeats.log (wall times)
#   TALLYD=path               tallyd to run (default build-gpu/server/tallyd)
#   REPEATS=N                 captures (default 3)
#   REPEATS_RESOLUTION=WxH    replaces 1280x720, e.g. 64x36 for a check on lavapipe
#   REPEATS_FRAMES=N          replaces the 20 frames per sample
set -uo pipefail
cd "$(dirname "$0")/../.."

# $out, $tallyd, $width and $height; Vulkan on the GPU machine (env.sh).
. tests/gpu/env.sh
tally_gpu_script repeats.sh REPEATS_RESOLUTION || exit 2
repeats="${REPEATS:-3}"
frames="${REPEATS_FRAMES:-20}"

spec="$out/repeats-spec.json"
python3 tests/gpu/spec_edit.py tests/gpu/repeats-atrium.json --resolution "${width}x${height}" \
  --frames "$frames" > "$spec" || exit 2
results=()
for i in $(seq 1 "$repeats"); do
  tally_timed_capture "repeats $i/$repeats atrium ${width}x${height}" "$spec" "$out/repeats-$i.json" \
    "$out/repeats-$i.log" "$out/repeats.log" || exit $?
  results+=(--result "$out/repeats-$i.json")
done
"$tallyd" repeats "${results[@]}" > "$out/repeats.txt" || exit 1
"$tallyd" repeats "${results[@]}" --json > "$out/repeats.json" || exit 1
cat "$out/repeats.txt"

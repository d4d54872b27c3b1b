#!/usr/bin/env bash
# The cost of counting in each mode (issue: counting at almost no cost), on
# the GPU: every renderer on Sponza at 1920x1080 (4 cameras, 400 lights) in
# exact, subgroup, sampled:64 and accumulate, and the compute passes
# (deferred and lean visibility-buffer shading in compute, volume fog, ray
# tracer) on atrium at 1920x1080 in exact, subgroup and accumulate. Prints
# the overhead by renderer and pass (counting_summary.py) and the counting
# error against exact (tallyd accuracy). Build first with tests/gpu/build.sh;
# bring .gl/ (run.sh) and .scenes/sponza (protocol.sh).
#
#   tests/gpu/counting_cost.sh
#   OUT=dir                  results (default ./gpu-out): counting-<name>.json, .log, .txt, counting.md
#   COUNTING_RESOLUTION=WxH  replaces 1920x1080 (e.g. 160x90 on lavapipe)
#   COUNTING_FRAMES=N        replaces the 10 frames per sample
#   COUNTING_SPECS="sponza compute"
#   COUNTING_MODES=a,b       replaces the specs' counting modes (e.g. exact,accumulate)
#   COUNTING_RENDERERS=a,b   keeps only these renderers and workloads of the specs (e.g. visbuffer-lean)
#   COUNTING_SITES=1         also runs each spec with per-site counts ("sites": true): counting-<name>-sites.*
#   COUNTING_FOOTPRINT=B     footprint on, B-byte blocks (32, 64 or 128); TALLY_FOOTPRINT_DEDUP chooses
#                            what its marks skip (docs/measurement.md, "What a mark skips")
set -uo pipefail
cd "$(dirname "$0")/../.."

. tests/gpu/env.sh
COUNTING_RESOLUTION="${COUNTING_RESOLUTION:-1920x1080}"
tally_gpu_script counting_cost.sh COUNTING_RESOLUTION || exit 2
frames="${COUNTING_FRAMES:-10}"
sponza="$(tally_sponza_path)"

status=0
results=()
names=()
for name in ${COUNTING_SPECS:-sponza compute}; do
  names+=("$name")
  [ -n "${COUNTING_SITES:-}" ] && names+=("$name-sites")
done
for name in "${names[@]}"; do
  spec="$out/counting-$name-spec.json"
  python3 tests/gpu/spec_edit.py "tests/gpu/counting/${name%-sites}.json" --sponza "$sponza" \
    --resolution "${width}x${height}" --frames "$frames" ${COUNTING_MODES:+--counting "$COUNTING_MODES"} \
    ${COUNTING_RENDERERS:+--renderers "$COUNTING_RENDERERS"} \
    ${COUNTING_FOOTPRINT:+--footprint "$COUNTING_FOOTPRINT"} \
    $([ "$name" != "${name%-sites}" ] && echo --sites) > "$spec" || { status=2; continue; }
  tally_timed_capture "counting $name ${width}x${height}" "$spec" "$out/counting-$name.json" \
    "$out/counting-$name.log" "$out/counting.log" || { status=$?; continue; }
  "$tallyd" accuracy --result "$out/counting-$name.json" > "$out/counting-$name.txt" || status=1
  results+=("$out/counting-$name.json")
done
[ ${#results[@]} -gt 0 ] && python3 tests/gpu/counting_summary.py "${results[@]}" | tee "$out/counting.md"
exit "$status"

#!/usr/bin/env bash
# The cost of counting before and after a change, in one session on one
# machine: counting_cost.sh with tallyd of another build (TALLYD_BEFORE),
# then with this tree's build-gpu, both in exact and accumulate (exact is
# each run's own reference, so the two accumulate columns compare), then the
# GPU exactness tests of this tree. Prints both tables and the accuracy of
# accumulate against exact for each.
#
#   TALLYD_BEFORE=build-before/server/tallyd tests/gpu/counting_before_after.sh
#   OUT=dir   before/ and after/ (counting_cost.sh's files), exactness.log, renderers.log
#   COUNTING_SPECS, COUNTING_RESOLUTION, COUNTING_FRAMES as for counting_cost.sh
#   RENDERER_FILTER  gtest filter of the renderer tests run after run.sh (default:
#                    draws, sites per line and the material split)
#   BEFORE_AFTER_TESTS=0  the costs only, no tests
set -uo pipefail
cd "$(dirname "$0")/../.."
out="${OUT:-./gpu-out}"
mkdir -p "$out"
status=0
before="${TALLYD_BEFORE:?TALLYD_BEFORE names the tallyd to compare with}"
for side in before after; do
  tallyd_side=build-gpu/server/tallyd
  [ "$side" = before ] && tallyd_side="$before"
  echo "== $side ($tallyd_side)"
  TALLYD="$tallyd_side" OUT="$out/$side" COUNTING_MODES="${COUNTING_MODES:-exact,accumulate}" \
    bash tests/gpu/counting_cost.sh || status=1
  rm -rf "$out/$side"/*-screenshots  # what the capture drew: not what this compares
  for t in "$out/$side"/counting-*.txt; do
    echo "-- $(basename "$t")"; head -20 "$t"
  done
done
[ "${BEFORE_AFTER_TESTS:-1}" = 1 ] || exit "$status"
. tests/gpu/env.sh
tally_gpu_env || exit 2
OUT="$out" bash tests/gpu/run.sh > "$out/exactness.log" 2>&1 || status=1
tail -3 "$out/exactness.log"
TALLY_SHADER_DIR="$PWD/shaders" build-gpu/tests/renderers/tally_renderer_tests \
  --gtest_filter="${RENDERER_FILTER:-*RendererDraws*:*SitesPerLine*:*GltfMaterialSplit*}" \
  > "$out/renderers.log" 2>&1 || status=1
tail -3 "$out/renderers.log"
exit "$status"

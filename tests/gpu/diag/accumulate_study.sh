#!/usr/bin/env bash
# What the accumulate mode's parts cost, and other ways to flush
# (docs/measurement.md, "The accumulate mode's cost, part by part"):
# counting_cost.sh's specs (default: compute, atrium at 1920x1080) once per
# variant of TALLY_ACCUMULATE_STUDY, each run against its own uninstrumented
# frames; the variants that keep every count also run exact, so that
# `tallyd accuracy` shows their error. Then the GPU exactness tests and the
# renderers' analytic counts (run.sh), and the renderer tests of draws, sites
# and the material split. Build first with tests/gpu/build.sh.
#
#   tests/gpu/diag/accumulate_study.sh
#   OUT=dir               results (default ./gpu-out): <variant>.log, <variant>/counting.md, study.txt
#   STUDY_VARIANTS="..."  the variants (default below; "base" is the mode as it is)
#   STUDY_SPECS="..."     counting_cost.sh's specs (default compute)
#   STUDY_EXACTNESS=a,b   the variant the tests run with (default base: the mode as it is; none: no tests)
set -uo pipefail
cd "$(dirname "$0")/../../.."
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
variants="${STUDY_VARIANTS:-base elected-adds,split-reductions,waterfall-each no-flush no-adds no-adds,no-flush elected-adds split-reductions waterfall-each inline-flush}"
status=0
for v in $variants; do
  study="$v"
  [ "$v" = base ] && study=""
  modes=accumulate
  case "$v" in no-*) ;; *) modes=exact,accumulate ;; esac
  start=$(date +%s)
  TALLY_ACCUMULATE_STUDY="$study" OUT="$out/$v" COUNTING_SPECS="${STUDY_SPECS:-compute}" COUNTING_MODES="$modes" \
    timeout 150 bash tests/gpu/counting_cost.sh > "$out/$v.log" 2>&1 || status=1
  {
    echo "== $v ($(( $(date +%s) - start )) s)"
    cat "$out/$v/counting.md" 2>/dev/null | grep -v "^$" | grep -E "^\| (renderer|---|deferred|visbuffer|volume|raytrace)" | head -80
    grep -h " accumulate " "$out/$v"/counting-*.txt 2>/dev/null | head -8
  } | tee -a "$out/study.txt"
  rm -rf "$out/$v"/*-screenshots
done
exactness="${STUDY_EXACTNESS:-base}"
if [ "$exactness" != none ]; then
  [ "$exactness" = base ] && exactness=""
  export TALLY_ACCUMULATE_STUDY="$exactness"
  OUT="$out/exactness" timeout 150 bash tests/gpu/run.sh > "$out/exactness.log" 2>&1 || status=1
  . tests/gpu/env.sh
  tally_gpu_env
  TALLY_SHADER_DIR="$PWD/shaders" timeout 120 build-gpu/tests/renderers/tally_renderer_tests \
    --gtest_filter='*RendererDraws*:*SitesPerLine*:*GltfMaterialSplit*' > "$out/renderers.log" 2>&1 || status=1
  { echo "== tests with ${exactness:-the mode as it is}"
    grep -E "PASSED|FAILED|tests ran|run.sh:" "$out/exactness.log" "$out/renderers.log" | head -20; } | tee -a "$out/study.txt"
fi
exit "$status"

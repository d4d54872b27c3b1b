#!/usr/bin/env bash
# What footprint's marks cost with each choice of what they skip
# (docs/measurement.md, "What a mark skips"): counting_cost.sh's Sponza spec
# with accumulate and 64-byte blocks, once per TALLY_FOOTPRINT_DEDUP value,
# each capture against its own uninstrumented frames; then the footprint
# tests on the device (the integration cases, the renderers' analytic
# footprints), with the default choice. Build first with tests/gpu/build.sh;
# bring .gl/ (run.sh) and .scenes/sponza (protocol.sh).
#
#   tests/gpu/diag/footprint_dedup.sh
#   OUT=dir            results (default ./gpu-out): <choice>.log, <choice>/counting.md, dedup.txt
#   DEDUPS="a b"       the choices (default: none loops,lanes); "loops+fp-quad,fp-aliased" also sets
#                      TALLY_ACCUMULATE_STUDY (docs/measurement.md, "What a mark costs")
#   DEDUP_SPECS="..."  counting_cost.sh's specs (default sponza)
#   DEDUP_TESTS=0      no tests
set -uo pipefail
cd "$(dirname "$0")/../../.."
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
status=0
for d in ${DEDUPS:-none loops,lanes}; do
  start=$(date +%s)
  study=""
  [[ "$d" == *+* ]] && study="${d#*+}"
  TALLY_ACCUMULATE_STUDY="$study" TALLY_FOOTPRINT_DEDUP="${d%%+*}" OUT="$out/$d" COUNTING_SPECS="${DEDUP_SPECS:-sponza}" COUNTING_MODES=accumulate \
    COUNTING_FOOTPRINT=64 timeout 240 bash tests/gpu/counting_cost.sh > "$out/$d.log" 2>&1 || status=1
  {
    echo "== $d ($(( $(date +%s) - start )) s)"
    grep -v "^$" "$out/$d/counting.md" 2>/dev/null | grep -vE "Register Count|^\| renderer \| pass \| stages" | head -60
  } | tee -a "$out/dedup.txt"
  rm -rf "$out/$d"/*-screenshots
done
if [ "${DEDUP_TESTS:-1}" != 0 ]; then
  OUT="$out/tests" timeout 150 bash tests/gpu/run.sh build-gpu/tests/integration \
    --gtest_filter='*Footprint*:*ExecutedArithmetic*' > "$out/exactness.log" 2>&1 || status=1
  . tests/gpu/env.sh
  tally_gpu_env
  TALLY_SHADER_DIR="$PWD/shaders" timeout 150 build-gpu/tests/renderers/tally_renderer_tests \
    --gtest_filter='*Footprint*' > "$out/renderers.log" 2>&1 || status=1
  { echo "== footprint tests, default choice"
    grep -hE "^\[  (PASSED|FAILED)|tests ran" "$out/tests/exactness.log" "$out/exactness.log" "$out/renderers.log" | head -20; } |
    tee -a "$out/dedup.txt"
fi
exit "$status"

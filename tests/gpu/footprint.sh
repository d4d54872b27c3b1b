#!/usr/bin/env bash
# Footprint on the GPU test machine: the analytic cases (the integration
# suite's Footprint tests and the renderers' RendererFootprint tests), then
# the founding protocol on Sponza with footprint (64-byte blocks), summarised
# beside requested bytes with each pass's roofline figures. Build first with
# tests/gpu/build.sh; .gl/ and .scenes/sponza as for protocol.sh.
#
#   tests/gpu/footprint.sh            FOOTPRINT_PROTOCOL=0 skips the protocol
#   OUT=dir  where results go (default ./gpu-out): footprint-analytic.{json,log},
#            footprint-renderers.{json,log}, footprint/ (protocol.sh's files), footprint-summary.txt
set -uo pipefail
cd "$(dirname "$0")/../.."

out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
. tests/gpu/env.sh
tally_gpu_env || exit 2

status=0
TALLY_SHADER_DIR="$PWD/build-gpu/tests/integration/shaders" build-gpu/tests/integration/tally_exactness_tests \
  --gtest_filter='*Footprint*' --gtest_output="json:$out/footprint-analytic.json" \
  > "$out/footprint-analytic.log" 2>&1 || status=1
TALLY_SHADER_DIR="$PWD/shaders" build-gpu/tests/renderers/tally_renderer_tests \
  --gtest_filter='*RendererFootprint*' --gtest_output="json:$out/footprint-renderers.json" \
  > "$out/footprint-renderers.log" 2>&1 || status=1
tail -3 "$out/footprint-analytic.log" "$out/footprint-renderers.log"

if [ "${FOOTPRINT_PROTOCOL:-1}" = 1 ]; then
  OUT="$out/footprint" tests/gpu/protocol.sh tests/gpu/sponza-protocol-footprint.json > /dev/null || status=1
  tail -2 "$out/footprint/protocol.log"
  rm -rf "$out/footprint/protocol-screenshots"
  python3 tests/gpu/footprint_summary.py "$out/footprint/protocol.json" | tee "$out/footprint-summary.txt"
  gzip -f "$out/footprint/protocol.json"
fi
exit "$status"

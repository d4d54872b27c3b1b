#!/usr/bin/env bash
# Descriptor buffers (VK_EXT_descriptor_buffer) under the layer on the GPU
# test machine (lavapipe 22.3 does not offer the extension): build first with
# tests/gpu/build.sh; .gl/ as for run.sh. Runs tests/layer/descriptor_buffers_test.py
# on descriptor_buffer_app: its draw's and dispatch's counts against the
# sizes it was written with, every line named by its resource, and, where
# the Khronos validation layer is installed, stacked with it both ways.
# A device without the extension fails the run (TALLY_TEST_STRICT=1).
#   OUT=dir  (default ./gpu-out): descriptor-buffers.txt, descriptor-buffers/ (the outputs, validation logs)
#   BUILD_DIR=dir (default build-gpu)
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
build="${BUILD_DIR:-build-gpu}"
app="$build/tests/layer/tally_layer_descriptor_buffer_app"
[ -x "$app" ] || { echo "descriptor_buffers: no $app (run tests/gpu/build.sh)" >&2; exit 2; }
[ -f "$build/layer/VkLayer_tally_counters.json" ] || { echo "descriptor_buffers: no layer in $build/layer" >&2; exit 2; }
tally_gpu_env || exit 2
TALLY_TEST_STRICT=1 python3 tests/layer/descriptor_buffers_test.py --build "$build" --out "$out/descriptor-buffers" \
  2>&1 | tee "$out/descriptor-buffers.txt"
exit "${PIPESTATUS[0]}"

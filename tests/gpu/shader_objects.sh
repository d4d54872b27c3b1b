#!/usr/bin/env bash
# Shader objects (VK_EXT_shader_object) under the layer, on the GPU test
# machine: NVIDIA's driver offers them, lavapipe 22.3 does not. Build first
# with tests/gpu/build.sh (it builds tally_layer_shader_object_app); bring the
# Vulkan loader's .debs in .gl/ (see run.sh).
#
# tests/layer/shader_object_app.cpp draws a 64x64 target and dispatches 3,200
# invocations through shader objects; tests/layer/shader_objects_check.py
# checks every count against what the app's geometry and dispatch give, and
# against the pipeline statistics. Three cases:
#   separate  vertex and fragment shaders created apart, bound together
#   linked    created linked (VK_SHADER_CREATE_LINK_STAGE_BIT_EXT)
#   binary    the dispatch's shader created from vkGetShaderBinaryDataEXT:
#             not instrumented, reported with the reason, nothing counted
# A device without the extension fails the run (the app exits 77 and says so).
#
#   tests/gpu/shader_objects.sh
#   OUT=dir         where results go (default ./gpu-out): shader-objects-CASE.json, shader-objects.log
#   LAYER_DIR=dir   the layer's folder (default build-gpu/layer)
#   APP=path        the application (default build-gpu/tests/layer/tally_layer_shader_object_app)
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
layer_dir="${LAYER_DIR:-$PWD/build-gpu/layer}"
app="${APP:-$PWD/build-gpu/tests/layer/tally_layer_shader_object_app}"
[ -x "$app" ] || { echo "shader_objects.sh: no $app (run tests/gpu/build.sh, or set APP)" >&2; exit 2; }
[ -f "$layer_dir/VkLayer_tally_counters.json" ] || { echo "shader_objects.sh: no layer in $layer_dir" >&2; exit 2; }
tally_gpu_env || exit 2
log="$out/shader-objects.log"
: > "$log"
status=0
frames=2
for case in separate linked binary; do
  result="$out/shader-objects-$case.json"
  rm -f "$result"
  flags=(--frames 4)
  [ "$case" = linked ] && flags+=(--linked 1)
  [ "$case" = binary ] && flags+=(--binary 1)
  # One submission a frame; the first is skipped (creation), the next two counted.
  env VK_ADD_LAYER_PATH="$layer_dir" VK_INSTANCE_LAYERS=VK_LAYER_TALLY_counters \
    VK_LOADER_LAYERS_ENABLE=VK_LAYER_TALLY_counters TALLY_LAYER_OUTPUT="$result" TALLY_LAYER_FRAMES="$frames" \
    TALLY_LAYER_SKIP_FRAMES=1 TALLY_LAYER_FRAME_SUBMITS=1 TALLY_LAYER_STATISTICS_FRAMES=all \
    "$app" "${flags[@]}" >> "$log" 2>&1
  rc=$?
  if [ "$rc" -eq 77 ]; then
    echo "shader objects ($case): FAIL: the device offers no VK_EXT_shader_object" | tee -a "$log"
    status=1
    break
  elif [ "$rc" -ne 0 ]; then
    echo "shader objects ($case): FAIL: the application exited $rc under the layer" | tee -a "$log"
    status=1
    continue
  fi
  python3 tests/layer/shader_objects_check.py --output "$result" --case "$case" --frames "$frames" 2>&1 |
    tee -a "$log"
  [ "${PIPESTATUS[0]}" -eq 0 ] || status=1
done
tail -20 "$log"
exit "$status"

#!/usr/bin/env bash
# glTF scenes on the GPU machine (docs/scenes.md): the renderer tests of the
# glTF material features (alpha mask and blend, culling, samplers, uv sets and
# transforms, vertex colours, emission) on the NVIDIA driver, where the
# visibility buffers take the descriptor-indexing path with each texture's own
# sampler, and the four Khronos test models captured on every renderer.
# Build first with tests/gpu/build.sh; copy ../shared/scenes/khronos to
# .scenes/khronos (carried, git-ignored) and the loader packages to .gl/.
#   OUT=dir tests/gpu/scenes.sh    -> gltf_features.{json,log}, khronos.tgz (images, results)
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
tally_gpu_env || exit 2
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
build=build-gpu
export TALLY_SHADER_DIR="$PWD/shaders"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/device.txt" 2>&1
"$build/tests/renderers/tally_renderer_tests" --gtest_filter='Gltf*' --gtest_output="json:$out/gltf_features.json" \
  > "$out/gltf_features.log" 2>&1
echo "gltf features: exit $?" | tee -a "$out/device.txt"
KHRONOS_DIR="$PWD/.scenes/khronos" TALLYD="$PWD/$build/server/tallyd" \
  bash tests/scenes/khronos/run.sh "$out/khronos" > "$out/khronos.log" 2>&1
echo "khronos: exit $?" | tee -a "$out/device.txt"
tar czf "$out/khronos.tgz" -C "$out" khronos && rm -rf "$out/khronos"

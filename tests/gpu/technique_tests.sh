#!/usr/bin/env bash
# The technique tests (tests/renderers) on the GPU test machine: the paths
# lavapipe cannot run (hardware PCF, MSAA 2x and 8x, quad ops for the mesh
# density lanes, descriptor indexing) run here, with the same derived counts
# asserted. Build first with tests/gpu/build.sh; bring the Vulkan loader's
# .debs in .gl/ (see run.sh).
#
#   tests/gpu/technique_tests.sh [GTEST_FILTER]   default: every technique suite
#   OUT=dir   where results go (default ./gpu-out): technique-tests.log, technique-tests.xml
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
binary="${TESTS:-build-gpu/tests/renderers/tally_renderer_tests}"
[ -x "$binary" ] || { echo "technique_tests.sh: no $binary (run tests/gpu/build.sh)" >&2; exit 2; }
tally_gpu_env || exit 2
export TALLY_SHADER_DIR="$PWD/shaders"
filter="${1:-Shadow*:Msaa*:Density*:Lod*:Tbn*:TileMemory*:ComputeShading*:Workload*:VolumeFog*:Raytrace*:Bloom*:Overdraw*:Overshading*:RendererOptions*}"
"$binary" --gtest_filter="$filter" --gtest_output="xml:$out/technique-tests.xml" > "$out/technique-tests.log" 2>&1
rc=$?
grep -E "^\[  (PASSED|FAILED|SKIPPED) |^\[==========\]" "$out/technique-tests.log"
exit $rc

#!/usr/bin/env bash
# Runs the exactness tests on the GPU test machine (NVIDIA H100/H200: NVIDIA
# Vulkan driver installed, Vulkan loader not). Build first with
# tests/gpu/build.sh; bring the loader's Debian packages in .gl/ (see
# DESIGN.md "Devices"): libvulkan1, and libglvnd0 + libglx0 (the NVIDIA ICD,
# libGLX_nvidia.so.0, hands out no vkCreateInstance without GLVND's
# libGLdispatch). From the repository root, on any x86-64 Debian machine:
#   o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
#   mkdir -p .gl /tmp/amd64/partial; apt-get $o update
#   (cd .gl && apt-get $o download libvulkan1 libglvnd0 libglx0 libegl1 libgl1 libopengl0 libgles2)
#
#   tests/gpu/run.sh [BINARY_DIR]     BINARY_DIR defaults to build-gpu/tests/integration
#   OUT=dir  where results go (default ./gpu-out): exactness.json (gtest),
#            exactness_stats.json (statistics and timings), exactness.log,
#            analytic.json and analytic.log (the renderers' analytic counts)
#   Extra arguments after BINARY_DIR go to the test binary (e.g. --gtest_filter=...).
set -uo pipefail
cd "$(dirname "$0")/../.."

bin_dir="${1:-build-gpu/tests/integration}"
shift || true
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
if [ ! -x "$bin_dir/tally_exactness_tests" ]; then
  echo "run.sh: no test binary at $bin_dir/tally_exactness_tests (build it with tests/gpu/build.sh)" >&2
  exit 2
fi
bin_dir="$(cd "$bin_dir" && pwd)"
binary="$bin_dir/tally_exactness_tests"

# The Vulkan loader, the NVIDIA ICD and build-gpu/lib (env.sh).
. tests/gpu/env.sh
tally_gpu_env || exit 2

# Shaders travel next to the binary (build.sh copies them).
if [ -z "${TALLY_SHADER_DIR:-}" ] && [ -d "$bin_dir/shaders" ]; then
  export TALLY_SHADER_DIR="$bin_dir/shaders"
fi

# The binary writes exactness_stats.json into its working directory.
work="$(mktemp -d)"
(
  cd "$work" && "$binary" --gtest_output="json:$out/exactness.json" "$@"
) 2>&1 | tee "$out/exactness.log"
status=${PIPESTATUS[0]}
if [ -f "$work/exactness_stats.json" ]; then
  cp "$work/exactness_stats.json" "$out/exactness_stats.json"
else
  echo "run.sh: the tests wrote no exactness_stats.json" >&2
fi
rm -rf "$work"

# The renderers' analytic counts and the visibility-id capacity check, with
# the statistic beside every pass's count (asserted equal on NVIDIA). They
# read the renderers' shaders from the tree and need the libraries build.sh
# copied to build-gpu/lib.
renderer_tests="$bin_dir/../renderers/tally_renderer_tests"
if [ -x "$renderer_tests" ]; then
  TALLY_SHADER_DIR="$PWD/shaders" \
  LD_LIBRARY_PATH="$bin_dir/../../lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
    "$renderer_tests" --gtest_filter='*AnalyticCounts*:VisibilityIdCapacity.*' \
    --gtest_output="json:$out/analytic.json" 2>&1 | tee "$out/analytic.log"
  renderer_status=${PIPESTATUS[0]}
  [ "$status" -eq 0 ] && status=$renderer_status
else
  echo "run.sh: no $renderer_tests (build it with tests/gpu/build.sh)" >&2
  status=2
fi
echo "run.sh: tests exited with $status; results in $out"
exit "$status"

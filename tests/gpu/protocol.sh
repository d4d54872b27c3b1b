#!/usr/bin/env bash
# The founding study's protocol on the GPU test machine: Sponza at 1280x720
# and 1920x1080, every renderer, auto cameras, 20 frames. Build first with
# tests/gpu/build.sh; bring the Vulkan loader's .debs in .gl/ (see run.sh) and
# a copy of the Sponza folder in .scenes/sponza (git-ignored; ../shared does
# not travel with the tree).
#
#   tests/gpu/protocol.sh [SPEC]     SPEC defaults to tests/gpu/sponza-protocol.json
#   OUT=dir  where results go (default ./gpu-out): protocol.json, protocol-screenshots/,
#            protocol-summary.txt, protocol.log (with the wall time of the whole protocol)
set -uo pipefail
cd "$(dirname "$0")/../.."

spec_in="${1:-tests/gpu/sponza-protocol.json}"
out="${OUT:-./gpu-out}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"
tallyd="build-gpu/server/tallyd"
[ -x "$tallyd" ] || { echo "protocol.sh: no $tallyd (run tests/gpu/build.sh)" >&2; exit 2; }

# The Vulkan loader, the NVIDIA ICD and build-gpu/lib (env.sh).
. tests/gpu/env.sh
tally_gpu_env || exit 2
export TALLY_SHADER_DIR="$PWD/shaders"
sponza="$(tally_sponza_path)"
python3 tests/gpu/spec_edit.py "$spec_in" --sponza "$sponza" > "$out/protocol-spec.json" || exit 2

start=$(date +%s%N)
"$tallyd" capture --spec "$out/protocol-spec.json" --out "$out/protocol.json" --summary \
  > "$out/protocol-summary.txt" 2> "$out/protocol.log"
status=$?
end=$(date +%s%N)
echo "protocol wall time: $(( (end - start) / 1000000 )) ms, exit $status" | tee -a "$out/protocol.log"
tail -5 "$out/protocol.log"
head -80 "$out/protocol-summary.txt"
exit "$status"

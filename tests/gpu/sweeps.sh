#!/usr/bin/env bash
# Stability sweeps on the GPU: the depth-reconstruction sweep of
# tests/gpu/sweeps-depth.json (deferred, near 0.01 / 0.1 / 1 m, far 1000 m,
# distances 3 to 300 m, threshold 1e-4 relative) at 1280x720, the same points
# docs/measurement.md ("Sweep: depth reconstruction") reports on lavapipe.
# Build first with tests/gpu/build.sh; bring the Vulkan loader's .debs in .gl/
# (see run.sh).
#
#   tests/gpu/sweeps.sh
#   OUT=dir                 where results go (default ./gpu-out): sweep-depth.json, sweep-depth.log,
#                           sweep-depth.txt (a table of the points and fails_at)
#   TALLYD=path             tallyd to run (default build-gpu/server/tallyd)
#   SWEEP_RESOLUTION=WxH    replaces 1280x720, e.g. 64x36 for a check on lavapipe
set -uo pipefail
cd "$(dirname "$0")/../.."

# $out, $tallyd, $width and $height; Vulkan on the GPU machine (env.sh).
. tests/gpu/env.sh
tally_gpu_script sweeps.sh SWEEP_RESOLUTION || exit 2

spec="$out/sweep-depth-spec.json"
sed -e "s|\[1280, 720\]|[$width, $height]|" tests/gpu/sweeps-depth.json > "$spec"
start=$(date +%s%N)
"$tallyd" capture --spec "$spec" --out "$out/sweep-depth.json" 2> "$out/sweep-depth.log"
rc=$?
end=$(date +%s%N)
echo "sweep depth-reconstruction ${width}x${height}: wall time $(( (end - start) / 1000000 )) ms, exit $rc"
if [ "$rc" -ne 0 ]; then
  tail -5 "$out/sweep-depth.log"
  exit "$rc"
fi
python3 - "$out/sweep-depth.json" > "$out/sweep-depth.txt" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print("device:", r["device"].get("name"))
print("%-6s %-9s %-9s %-12s %-12s %-12s %s" % ("near", "far/near", "distance", "max_abs_m", "max_rel",
                                              "predicted", "measured/predicted"))
for p in r["points"]:
    print("%-6g %-9g %-9g %-12.3g %-12.3g %-12.3g %.2f" % (p["near"], p["far_over_near"], p["distance"],
          p["error"]["max_abs"], p["error"]["max_relative"], p["predicted"]["max_relative"],
          p["error_over_predicted"]))
print("fails_at:", json.dumps(r["fails_at"]))
print("predicted_fails_at:", json.dumps(r["predicted_fails_at"]))
PY
status=$?
cat "$out/sweep-depth.txt"
exit "$status"

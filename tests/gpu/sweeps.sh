#!/usr/bin/env bash
# Stability sweeps on the GPU: every sweep spec in tests/gpu/specs/ (or the
# names given), each run by `tallyd capture --spec` as the service's jobs run
# them. The specs hold the points docs/accuracy.md and docs/measurement.md
# report. Build first with tests/gpu/build.sh; bring the Vulkan loader's .debs
# in .gl/ (see run.sh).
#
#   tests/gpu/sweeps.sh [NAME...]     NAME: a spec in tests/gpu/specs/ without .json
#                                     (depth, precision, edges, ids); default all
#   OUT=dir                 where results go (default ./gpu-out): sweep-NAME.json (the
#                           result), sweep-NAME.log, sweep-NAME.txt (fails_at and, per
#                           plot, the points as a table)
#   TALLYD=path             tallyd to run (default build-gpu/server/tallyd)
#   SWEEP_RESOLUTION=WxH    replaces each spec's resolution, e.g. 64x36 for a quick
#                           check on lavapipe; without it the specs' own are used
set -uo pipefail
cd "$(dirname "$0")/../.."

# $out, $tallyd; Vulkan on the GPU machine (env.sh).
. tests/gpu/env.sh
override="${SWEEP_RESOLUTION:-}"
tally_gpu_script sweeps.sh SWEEP_RESOLUTION || exit 2

names=("$@")
if [ ${#names[@]} -eq 0 ]; then
  for f in tests/gpu/specs/*.json; do names+=("$(basename "$f" .json)"); done
fi

status=0
for name in "${names[@]}"; do
  source_spec="tests/gpu/specs/$name.json"
  [ -f "$source_spec" ] || { echo "sweeps.sh: no $source_spec" >&2; status=2; continue; }
  spec="$out/sweep-$name-spec.json"
  python3 tests/gpu/spec_edit.py "$source_spec" ${override:+--resolution "$override"} > "$spec" \
    || { status=2; continue; }
  tally_timed_capture "sweep $name" "$spec" "$out/sweep-$name.json" "$out/sweep-$name.log" || { status=$?; continue; }
  # Fails_at, then one table per plot: the x value, the series values and y.
  python3 - "$out/sweep-$name.json" > "$out/sweep-$name.txt" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
def at(p, path):
    for k in path.split("."):
        p = p.get(k) if isinstance(p, dict) else None
    return p
print("sweep:", r["sweep"], " device:", r["device"].get("name"), " resolution:", r.get("resolution", r["spec"].get("resolution")))
print("threshold:", json.dumps(r["threshold"]))
print("fails_at:", json.dumps(r["fails_at"]))
if "predicted_fails_at" in r:
    print("predicted_fails_at:", json.dumps(r["predicted_fails_at"]))
for plot in r.get("plots", []):
    print()
    print("## %s  (%s against %s)" % (plot["title"], plot["y"], plot["x"]))
    cols = plot["series"] + [plot["x"], plot["y"]]
    print("  ".join("%-14s" % c for c in cols))
    for p in r["points"]:
        vals = [at(p, c) for c in cols]
        print("  ".join("%-14.6g" % v if isinstance(v, (int, float)) and not isinstance(v, bool) else "%-14s" % v for v in vals))
PY
  rc=$?
  cat "$out/sweep-$name.txt"
  [ "$rc" -eq 0 ] || status=$rc
done
exit "$status"

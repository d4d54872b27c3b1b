#!/usr/bin/env bash
# Where the lighting passes' bytes go as the number of lights grows: forward
# and deferred on Sponza with per-site counts ("sites": true), one camera,
# at SITES_LIGHTS lights (default 25 100 400). Prints each pass's top source
# lines and their shares per light count (docs/results-gpu.md). Build first
# with tests/gpu/build.sh; bring .gl/ and .scenes/sponza.
#
#   OUT=dir tests/gpu/sites_lights.sh    -> sites-lights-<N>.json, sites-lights.md
#   COUNTING_RESOLUTION=WxH              replaces 1920x1080
set -uo pipefail
cd "$(dirname "$0")/../.."

. tests/gpu/env.sh
COUNTING_RESOLUTION="${COUNTING_RESOLUTION:-1920x1080}"
tally_gpu_script sites_lights.sh COUNTING_RESOLUTION || exit 2
sponza="$(tally_sponza_path)"
status=0
results=()
for lights in ${SITES_LIGHTS:-25 100 400}; do
  spec="$out/sites-lights-$lights-spec.json"
  python3 - "$sponza" "$width" "$height" "$lights" > "$spec" <<'PY' || { status=2; continue; }
import json, sys
sponza, w, h, lights = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
print(json.dumps({"renderers": ["forward", "deferred"], "scenes": [{"gltf": sponza}], "resolutions": [[w, h]],
                  "cameras": [{"eye": [-6.438, 9.568, -0.310], "target": [-1.801, 16.126, 4.327], "fov_deg": 60}],
                  "frames": 5, "counted_frames": 1, "counting": "accumulate", "lights": lights, "sites": True,
                  "ceilings": False}))
PY
  tally_timed_capture "sites lights $lights" "$spec" "$out/sites-lights-$lights.json" "$out/sites-lights-$lights.log" \
    "$out/sites-lights.log" || { status=$?; continue; }
  results+=("$out/sites-lights-$lights.json")
done
[ ${#results[@]} -gt 0 ] && python3 - "${results[@]}" <<'PY' | tee "$out/sites-lights.md"
import json, sys
print("| lights | renderer | pass | pass bytes | top line | its share | second line | its share |")
print("|---|---|---|---|---|---|---|---|")
for path in sys.argv[1:]:
    result = json.load(open(path))
    lights = result["spec"]["lights"]
    for run in result["runs"]:
        for p in run["samples"][0]["passes"]:
            if p["name"] not in ("forward", "lighting", "gbuffer"):
                continue
            lines = {}
            for s in p.get("sites", []):
                key = "%s:%s %s" % (s["file"], s["line"], s["resource"])
                lines[key] = lines.get(key, 0) + s["bytes"]
            top = sorted(lines.items(), key=lambda kv: -kv[1])[:2] + [("-", 0), ("-", 0)]
            total = p["bytes"] or 1
            print("| %d | %s | %s | %.1f MB | %s | %.1f %% | %s | %.1f %% |" % (
                lights, run["renderer"], p["name"], p["bytes"] / 1e6, top[0][0], 100 * top[0][1] / total,
                top[1][0], 100 * top[1][1] / total))
PY
exit "$status"

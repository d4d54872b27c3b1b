#!/usr/bin/env bash
# The camera heatmap on the GPU machine, through the daemon: tallyd serve on a
# fresh SQLite store with Sponza's folder as --scenes, tests/gpu/heatmap-sponza.json
# posted (deferred and visbuffer over a floor grid of Sponza), then
# GET /api/heatmap for frame time and bytes (visbuffer against deferred) and
# the top-down plan, and a text summary.
#
#   tests/gpu/heatmap.sh          OUT=dir (default ./gpu-out): heatmap/{spec,capture,frame_ms,bytes}.json,
#                                 heatmap/topdown.png, heatmap/summary.txt, heatmap/serve.log
#   RESOLUTION=1920x1080          the resolution
#   CELLS=12x6 YAWS=4             the grid (columns along x, rows along z) and directions per cell,
#                                 over the spec's region: Sponza's ground floor inside its outer
#                                 walls (x -11.4 .. 10.5, z -5.1 .. 4.6, read off its plan)
#   FRAMES=6 COUNTED=1            timed and counted frames per sample
#   About 3-4 minutes on an H100 or H200 at the defaults: 68 of the 72 cells
#   have floor (lavapipe placement, the same code), 272 poses, each 2 x (1
#   counted + 6 timed frames) and a forward reference frame, with Sponza at
#   1080p about 34 ms a frame there (docs/results-gpu.md, crossover); plus
#   loading Sponza and storing 544 screenshots. Halve YAWS to halve it.
#   TALLYD=path                   another tallyd (e.g. a lavapipe build, with
#                                 RESOLUTION=64x36 CELLS=4x2 YAWS=1 FRAMES=2 to try the path)
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
tally_gpu_script heatmap RESOLUTION || exit 2
[ -n "${RESOLUTION:-}" ] || { width=1920; height=1080; }
dir="$out/heatmap"
mkdir -p "$dir"
rm -f "$dir/tally.db" "$dir/tally.db-wal" "$dir/tally.db-shm"
tallyd="$(cd "$(dirname "$tallyd")" && pwd)/$(basename "$tallyd")"
sponza="$(tally_sponza_path)"
[ -f "$sponza" ] || { echo "heatmap: no Sponza at $sponza (cp -r ../shared/scenes/sponza .scenes/)" >&2; exit 2; }

cells="${CELLS:-12x6}"
case "$cells" in
  [0-9]*x[0-9]*) ;;
  *) echo "heatmap: CELLS must be CxR, got '$cells'" >&2; exit 2 ;;
esac
python3 - "$dir/spec.json" "$width" "$height" "${cells%x*}" "${cells#*x}" "${YAWS:-4}" "${FRAMES:-6}" \
  "${COUNTED:-1}" "$(basename "$sponza")" <<'PY'
import json, sys
out, w, h, cols, rows, yaws, frames, counted, gltf = sys.argv[1:10]
spec = json.load(open("tests/gpu/heatmap-sponza.json"))
spec["scenes"] = [{"gltf": gltf}]
spec["resolutions"] = [[int(w), int(h)]]
spec["heatmap"]["cells"] = [int(cols), int(rows)]
spec["heatmap"]["yaws"] = int(yaws)
spec["frames"] = int(frames)
spec["counted_frames"] = min(int(counted), int(frames))
json.dump(spec, open(out, "w"), indent=1)
PY

port="${PORT:-18378}"
"$tallyd" serve --db "$dir/tally.db" --port "$port" --web "$PWD/web" --job-deadline 1500 \
  --scenes "$(dirname "$sponza")" > "$dir/serve.out" 2> "$dir/serve.log" &
daemon=$!
trap 'kill $daemon 2>/dev/null; wait $daemon 2>/dev/null' EXIT

python3 - "$port" "$dir" <<'PY'
import json, math, sys, time, urllib.error, urllib.request
port, out = sys.argv[1], sys.argv[2]
base = "http://127.0.0.1:%s" % port
def call(method, path, body=None, raw=False):
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(base + path, data=data, method=method,
                                 headers={"Content-Type": "application/json"} if data else {})
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            payload = r.read()
    except urllib.error.HTTPError as e:
        sys.exit("%s %s: %d %s" % (method, path, e.code, e.read().decode(errors="replace")))
    return payload if raw else json.loads(payload)
for _ in range(120):
    try:
        call("GET", "/api/health")
        break
    except Exception:
        time.sleep(0.5)
start = time.time()
job = call("POST", "/api/captures", json.load(open(out + "/spec.json")))["id"]
last = ""
while True:
    j = call("GET", "/api/captures/%d" % job)
    if j["status"] in ("done", "failed", "cancelled"):
        break
    p = j.get("progress") or {}
    line = "%s/%s %s" % (p.get("done"), p.get("total"), p.get("current") or "")
    if line != last:
        print("  %.0f s: %s" % (time.time() - start, line), flush=True)
        last = line
    time.sleep(5)
j["wall_s"] = time.time() - start
json.dump(j, open(out + "/capture.json", "w"), indent=1)
print("capture %d %s in %.0f s %s" % (job, j["status"], j["wall_s"], j.get("error") or ""))
if j["status"] != "done":
    sys.exit(1)
json.dump(call("GET", "/api/hosts"), open(out + "/hosts.json", "w"), indent=1)
maps = {}
for metric in ("frame_ms", "bytes"):
    m = call("GET", "/api/heatmap?capture=%d&renderer=deferred&versus=visbuffer&metric=%s" % (job, metric))
    json.dump(m, open("%s/%s.json" % (out, metric), "w"), indent=1)
    maps[metric] = m
for yaw in ("worst",):
    m = call("GET", "/api/heatmap?capture=%d&renderer=deferred&versus=visbuffer&metric=frame_ms&yaw=%s" % (job, yaw))
    json.dump(m, open("%s/frame_ms-%s.json" % (out, yaw), "w"), indent=1)
open(out + "/topdown.png", "wb").write(call("GET", "/api/heatmap/%d/topdown.png" % job, raw=True))

# The summary: the grid of ratios (visbuffer / deferred; * significant) and where visbuffer wins.
lines = []
m = maps["frame_ms"]
lay = m["layout"]
lines.append("capture %d: %s %dx%d on %s, %dx%d cells of %.2f x %.2f m, %d yaws, eye %.2f m over ground %.3f" % (
    job, m["scene"], m["width"], m["height"], m["device"], lay["columns"], lay["rows"], lay["cell_size"][0],
    lay["cell_size"][1], len(lay["yaws_deg"]), lay["eye_height"], lay["ground"] if lay["ground"] is not None else float("nan")))
lines.append("capture wall time %.0f s; cells with floor %d, empty %s" % (j["wall_s"], lay["cells_with_floor"],
                                                                          json.dumps(lay["empty_counts"])))
for metric, mm in maps.items():
    s = mm["summary"]
    lines.append("")
    lines.append("%s: visbuffer / deferred per cell (mean over yaws); * significant; . no floor" % metric)
    lines.append("rows along z from %.1f (top), columns along x from %.1f" % (lay["origin"][1], lay["origin"][0]))
    for r in range(lay["rows"]):
        row = []
        for c in range(lay["columns"]):
            cell = mm["cells"][r * lay["columns"] + c]
            row.append("%7s" % (("%.3f%s" % (cell["ratio"], "*" if cell["significant"] else " ")) if cell["ratio"] is not None else "."))
        lines.append(" ".join(row))
    if s.get("ratio"):
        def where(ref):
            x = lay["origin"][0] + (ref["column"] + 0.5) * lay["cell_size"][0]
            z = lay["origin"][1] + (ref["row"] + 0.5) * lay["cell_size"][1]
            return "cell %d,%d (x %.1f, z %.1f)" % (ref["column"], ref["row"], x, z)
        r = s["ratio"]
        lines.append("median ratio %.4f, geometric mean %.4f; best for visbuffer (lowest ratio) at %s: %.4f (%+.1f %%), "
                     "worst (highest) at %s: %.4f (%+.1f %%)" % (r["median"], r["geometric_mean"], where(r["min"]),
                     r["min"]["value"], (r["min"]["value"] - 1) * 100, where(r["max"]), r["max"]["value"],
                     (r["max"]["value"] - 1) * 100))
        lines.append("significant in %d of %d cells: visbuffer lower in %d, higher in %d" % (
            s["significant"], s["cells_measured"], s["b_lower"], s["b_higher"]))
        a = s["a"]
        lines.append("deferred: median %.4g, from %.4g to %.4g" % (a["median"], a["min"]["value"], a["max"]["value"]))
text = "\n".join(lines) + "\n"
open(out + "/summary.txt", "w").write(text)
print(text)
PY

#!/usr/bin/env bash
# The crossover capture on the GPU machine, through the daemon: tallyd serve
# on a fresh SQLite store, tests/gpu/crossover-atrium.json posted (cameras
# cut to CAMERAS of the spec's automatic set, frames to FRAMES, to fit the
# machine's time), then GET /api/crossover for bytes and frame time, and at
# each resolution GET /api/compare's significance of the variants' frame times.
#
#   tests/gpu/crossover.sh        OUT=dir (default ./gpu-out): crossover/{spec,capture,bytes,frame_ms,significance,frames}.json,
#                                 crossover/serve.log
#   CAMERAS=2 FRAMES=10           the defaults
#   SCENE=sponza                  Sponza (.scenes/sponza, else ../shared's) with its 10 automatic
#                                 cameras instead of the atrium's fixed ones; EVERY=2 keeps every
#                                 second resolution of the spec
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
tally_gpu_script crossover RESOLUTION || exit 2
dir="$out/crossover"
mkdir -p "$dir"
tallyd="$(cd "$(dirname "$tallyd")" && pwd)/$(basename "$tallyd")"

python3 - "$dir/spec.json" "${CAMERAS:-2}" "${FRAMES:-10}" "${SCENE:-atrium}" "$(tally_sponza_path)" \
  "${EVERY:-1}" <<'EOF'
import json, sys
out, cameras, frames, scene, sponza, every = sys.argv[1:7]
spec = json.load(open("tests/gpu/crossover-atrium.json"))
if scene == "sponza":
    spec["scenes"] = [{"gltf": sponza}]
    spec["cameras"] = "auto"
else:
    # The repeats spec's atrium cameras: fixed poses, the first CAMERAS of them.
    spec["cameras"] = json.load(open("tests/gpu/repeats-atrium.json"))["cameras"][: int(cameras)]
spec["resolutions"] = spec["resolutions"][:: int(every)]
spec["frames"] = int(frames)
json.dump(spec, open(out, "w"), indent=1)
EOF

port=18377
scenes=()
[ "${SCENE:-atrium}" = sponza ] && scenes=(--scenes "$(dirname "$(tally_sponza_path)")")
"$tallyd" serve --db "$dir/tally.db" --port "$port" --web "$PWD/web" --job-deadline 1500 "${scenes[@]}" \
  > "$dir/serve.out" 2> "$dir/serve.log" &
daemon=$!
trap 'kill $daemon 2>/dev/null; wait $daemon 2>/dev/null' EXIT

python3 - "$port" "$dir" <<'EOF'
import json, sys, time, urllib.request
port, out = sys.argv[1], sys.argv[2]
base = "http://127.0.0.1:%s" % port
def call(method, path, body=None):
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(base + path, data=data, method=method,
                                 headers={"Content-Type": "application/json"} if data else {})
    with urllib.request.urlopen(req, timeout=60) as r:
        return json.loads(r.read())
for _ in range(120):
    try:
        call("GET", "/api/health")
        break
    except Exception:
        time.sleep(0.5)
start = time.time()
job = call("POST", "/api/captures", json.load(open(out + "/spec.json")))["id"]
while True:
    j = call("GET", "/api/captures/%d" % job)
    if j["status"] in ("done", "failed", "cancelled"):
        break
    time.sleep(2)
j["wall_s"] = time.time() - start
json.dump(j, open(out + "/capture.json", "w"), indent=1)
print("capture %d %s in %.0f s %s" % (job, j["status"], j["wall_s"], j.get("error") or ""))
if j["status"] != "done":
    sys.exit(1)
hosts = call("GET", "/api/hosts")
json.dump(hosts, open(out + "/hosts.json", "w"), indent=1)
for metric in ("bytes", "frame_ms"):
    c = call("GET", "/api/crossover?capture=%d&metric=%s" % (job, metric))
    json.dump(c, open("%s/%s.json" % (out, metric), "w"), indent=1)
    for s in c["series"]:
        f = s.get("fit")
        if f:
            print("%s %s: a %.4g [%.4g, %.4g], b %.4g per pixel [%.4g, %.4g], R2 %.4f%s" % (
                metric, s["variant"], f["a"], f["a_ci"][0], f["a_ci"][1], f["b"], f["b_ci"][0], f["b_ci"][1],
                f["r2"], " (poor fit)" if f["poor_fit"] else ""))
        else:
            print("%s %s: no fit: %s" % (metric, s["variant"], s.get("error")))
    for x in c["crossings"]:
        print("%s %s vs %s: %s %s" % (metric, x["first"], x["second"], x["kind"],
                                      json.dumps({k: x.get(k) for k in ("pixels", "pixels_ci", "resolution",
                                                                         "resolution_ci", "lower_below",
                                                                         "lower_above", "lower_throughout")})))
# At each resolution, every later variant against the first: frame times
# tested over the per-frame times of all cameras (GET /api/compare's
# significance), so the crossing can be read against what each resolution
# shows on its own.
runs = call("GET", "/api/runs?capture=%d&limit=1000" % job)["runs"]
by_res = {}
for r in runs:
    by_res.setdefault((r["width"], r["height"]), []).append(r)
rows = []
for (w, h), rs in sorted(by_res.items(), key=lambda kv: kv[0][0] * kv[0][1]):
    rs.sort(key=lambda r: r["variant"])
    ids = ",".join(str(r["id"]) for r in rs[:4])
    for strata in ("cameras", "none"):
        c = call("GET", "/api/compare?runs=%s&strata=%s" % (ids, strata))
        for s in c["significance"]:
            f = s.get("frame")
            b = next(r for r in rs if r["id"] == s["run_b"])
            row = {"width": w, "height": h, "a": rs[0]["variant"], "b": b["variant"], "strata": strata,
                   "cameras": s.get("cameras")}
            if f:
                row.update({"ratio": f["ratio"], "lower": f["interval"]["lower"], "upper": f["interval"]["upper"],
                            "p": f["mann_whitney"]["p"], "cliffs_delta": f["cliffs_delta"]["delta"],
                            "verdict": f["verdict"], "n": f["n_a"]})
                print("frame %dx%d %s vs %s (%s): ratio %.4f [%s, %s] p %.3g delta %+.2f %s" % (
                    w, h, b["variant"], rs[0]["variant"], strata, f["ratio"], f["interval"]["lower"],
                    f["interval"]["upper"], f["mann_whitney"]["p"], f["cliffs_delta"]["delta"], f["verdict"]))
            else:
                row["missing"] = s.get("frame_missing") or s.get("error")
            rows.append(row)
# Every sample's per-frame times, for analyses after the fact (the database
# itself, with its screenshots, is too large to bring back).
frames = []
for r in runs:
    for smp in call("GET", "/api/runs/%d/samples" % r["id"])["samples"]:
        full = call("GET", "/api/samples/%d" % smp["id"])
        frames.append({"run": r["id"], "variant": r["variant"], "width": r["width"], "height": r["height"],
                       "camera": smp["camera_index"], "frame_ms_frames": full.get("frame_ms_frames"),
                       "passes": {p["name"]: p.get("gpu_ms_frames") for p in full.get("passes", [])}})
json.dump(frames, open(out + "/frames.json", "w"))
json.dump(rows, open(out + "/significance.json", "w"), indent=1)
EOF

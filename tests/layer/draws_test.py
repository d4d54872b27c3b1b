#!/usr/bin/env python3
"""Counts per draw command under the Vulkan layer (TALLY_LAYER_DRAWS;
docs/layer.md, "Draws"), on lavapipe:

  draws_test.py --build BUILD_DIR --tallyd PATH --tally PATH --case app|capture

app: draws_app.cpp under the layer. Every draw is a triangle clipped to its
viewport of 48 rows, so its fragments are its columns x 48; each writes one
RGBA8 texel (4 bytes), the textured one also reads one; each vertex reads
two R32G32_SFLOAT attributes (8 bytes each). Each draw's count and bytes are
derived from that by hand, never from a run. Checked in exact and
accumulate counting, with TALLY_LAYER_DRAWS=1 and with TALLY_LAYER_SITES=1
(which turns draws on): each pass lists its draws in the order recorded,
named by the innermost debug label and the pipeline's debug name (its handle
where it has none; a secondary's draw without a label of its own takes the
executing pass's); an indirect command of two draws is one draw; the draws
(and the rest) sum to the pass's counted lines exactly; a recording's draws
beyond the 1024th share the rest; a pass lists its 256 heaviest and sums the
others into "draws_rest"; the lines are the same as without draws; a bad
TALLY_LAYER_DRAWS is refused by name.

capture: the daemon captures draws_app with an application spec's
"draws": true; the stored sample's draws, served by /api/samples/{id}/draws
and printed by `tally hotspots --by draw`, are the layer's.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from strict import skip_or_fail  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from attribution_test import layer_env  # noqa: E402
from layer_test import fail, load  # noqa: E402

W, H = 64, 48
MANY = 1100
CAP, LISTED = 1024, 256
VERTEX = 3 * 2 * 8  # one triangle's vertex reads: three vertices, two 8-byte attributes each


def draw(index, name, fragments, vertices=3, texels=0):
    """A draw's entry from its coverage: each fragment writes 4 bytes and
    reads `texels` texels of 4 bytes; each vertex reads two attributes."""
    read = vertices * 16 + fragments * texels * 4
    return {"index": index, "name": name, "count": fragments * (1 + texels) + vertices * 2,
            "bytes_read": read, "bytes_written": fragments * 4, "bytes": read + fragments * 4}


def listed(draws, rest_commands=0, rest=None):
    """The 256 heaviest (ties in recording order) and the rest summed."""
    order = sorted(draws, key=lambda d: -d["bytes"])
    rest = dict(rest or {"draws": 0, "count": 0, "bytes_read": 0, "bytes_written": 0, "bytes": 0})
    rest["draws"] += rest_commands
    for d in order[LISTED:]:
        rest["draws"] += 1
        for key in ("count", "bytes_read", "bytes_written", "bytes"):
            rest[key] += d[key]
    return order[:LISTED], (rest if rest["draws"] > 0 else None)


def expected_passes(unnamed):
    """Each pass's draw list and rest, by hand (draws_app.cpp's header)."""
    n = W * H
    scene = [draw(0, "floor \u00b7 opaque", n), draw(1, "left wall \u00b7 opaque", 16 * H),
             draw(2, "scene \u00b7 " + unnamed, 2 * 32 * H, vertices=6),
             draw(3, "indirect \u00b7 opaque", 2 * n, vertices=6),
             draw(4, "textured quad \u00b7 textured", 32 * H, texels=1)]
    secondary = [draw(0, "left half \u00b7 opaque", 32 * H), draw(1, "secondary \u00b7 opaque", n)]
    # The primary's first 1024 draws have regions of their own: the scene's
    # five, then the first 1019 of "many"; the others share the rest.
    own = CAP - len(scene)
    many = [draw(i, "many \u00b7 opaque", (1 + i % 16) * H) for i in range(MANY)]
    shared = {"draws": 0, "count": 0, "bytes_read": 0, "bytes_written": 0, "bytes": 0}
    for d in many[own:]:
        for key in ("count", "bytes_read", "bytes_written", "bytes"):
            shared[key] += d[key]
    return {"scene": (listed(scene), 5), "secondary": (listed(secondary), 2),
            "many": (listed(many[:own], MANY - own, shared), MANY)}


def counted_lines(p):
    read = sum(r["bytes"] for r in p["resources"] if r["source"] == "counter" and r["access"] == "read")
    written = sum(r["bytes"] for r in p["resources"] if r["source"] == "counter" and r["access"] == "write")
    return read, written


def run_app(args, tmp, name, extra, read=True):
    """The layer's output for draws_app under `extra`; its stderr where not `read`."""
    output = os.path.join(tmp, name + ".json")
    env = layer_env(args.build, output, 2, 0, frame_submits=1)
    env.update(extra)
    app = os.path.join(args.build, "tests", "layer", "tally_layer_draws_app")
    p = subprocess.run([app, "--frames", "3", "--many", str(MANY)], env=env, capture_output=True, text=True,
                       timeout=240)
    if p.returncode != 0:
        fail("%s: draws_app exited %d: %s" % (name, p.returncode, p.stderr[-2000:]))
    return load(output) if read else p.stderr


def check_frame(name, frame, failures):
    passes = {p["name"]: p for p in frame["passes"]}
    scene = passes.get("scene", {})
    unnamed = next((d["name"].split(" \u00b7 ", 1)[1] for d in scene.get("draw_list", []) if d["index"] == 2), "")
    if not unnamed.startswith("pipeline 0x"):
        failures.append("%s: the unnamed pipeline's draw is named %r, expected its handle" % (name, unnamed))
    for pass_name, ((want, want_rest), commands) in expected_passes(unnamed).items():
        p = passes.get(pass_name)
        if p is None:
            failures.append("%s: no pass %r among %s" % (name, pass_name, sorted(passes)))
            continue
        got = [{k: d[k] for k in ("index", "name", "count", "bytes_read", "bytes_written", "bytes")}
               for d in p.get("draw_list", [])]
        if got != want:
            at = next((i for i, (g, w) in enumerate(zip(got, want)) if g != w), min(len(got), len(want)))
            failures.append("%s, pass %s: %d draws listed, %d expected; at rank %d: %s, expected %s" %
                            (name, pass_name, len(got), len(want), at, got[at:at + 1], want[at:at + 1]))
        if p.get("draws_rest") != want_rest:
            failures.append("%s, pass %s: rest %s, expected %s" % (name, pass_name, p.get("draws_rest"), want_rest))
        if p["draws"] != commands:
            failures.append("%s, pass %s: %s draw commands, expected %d" % (name, pass_name, p["draws"], commands))
        rest = p.get("draws_rest") or {}
        sums = (sum(d["bytes_read"] for d in p.get("draw_list", [])) + rest.get("bytes_read", 0),
                sum(d["bytes_written"] for d in p.get("draw_list", [])) + rest.get("bytes_written", 0))
        if sums != counted_lines(p):
            failures.append("%s, pass %s: draws sum to %s (read, written), lines to %s" %
                            (name, pass_name, sums, counted_lines(p)))


def lines(output):
    return [[(p["name"], sorted((r["name"], r["access"], r["count"], r["bytes"]) for r in p["resources"]))
             for p in f["passes"]] for f in output["frames"]]


def case_app(args, tmp):
    failures = []
    runs = {
        "exact": {"TALLY_LAYER_COUNTING": "exact", "TALLY_LAYER_DRAWS": "1"},
        "accumulate": {"TALLY_LAYER_COUNTING": "accumulate", "TALLY_LAYER_DRAWS": "1"},
        "sites": {"TALLY_LAYER_COUNTING": "accumulate", "TALLY_LAYER_SITES": "1"},
    }
    plain = run_app(args, tmp, "plain", {"TALLY_LAYER_COUNTING": "accumulate"})
    if any("draw_list" in p or "draws_rest" in p for f in plain["frames"] for p in f["passes"]):
        failures.append("plain: a pass lists draws without TALLY_LAYER_DRAWS")
    for name, env in runs.items():
        out = run_app(args, tmp, name, env)
        if not out["layer"]["draws"] or len(out["frames"]) != 2:
            failures.append("%s: layer draws %s, %d frames" % (name, out["layer"]["draws"], len(out["frames"])))
            continue
        for frame in out["frames"]:
            check_frame(name, frame, failures)
        if lines(out) != lines(plain):
            failures.append("%s: the lines differ from the run without draws" % name)
    said = run_app(args, tmp, "bad", {"TALLY_LAYER_DRAWS": "yes"}, read=False)
    if "not counting: TALLY_LAYER_DRAWS: 'yes' is not 0 or 1" not in said:
        failures.append("TALLY_LAYER_DRAWS=yes: the layer said %r" % said[-400:])
    for f in failures:
        print("FAIL: " + f)
    if failures:
        sys.exit(1)
    print("draws: %d per pass as derived, in exact, accumulate and with sites; the cap and the rest" % (MANY + 7))


def case_capture(args, tmp):
    from clients_service import start_daemon  # the daemon with applications allowed
    apps = os.path.join(tmp, "apps")
    os.mkdir(apps)
    os.chmod(tmp, 0o755)
    app = shutil.copy2(os.path.join(args.build, "tests", "layer", "tally_layer_draws_app"), apps)
    args.layer_dir = os.path.join(args.build, "layer")
    daemon, api = start_daemon(args, tmp, apps)
    failures = []
    try:
        for _ in range(100):
            try:
                api.get("/api/health")
                break
            except OSError:
                time.sleep(0.1)
        spec = {"application": {"command": [app, "--frames", "3", "--many", str(MANY)], "frames": 2,
                                "frame_submits": 1, "timeout_s": 120}, "draws": True}
        job = api.wait(api.post("/api/captures", spec)["id"])
        if job["status"] != "done":
            fail("the capture job %s: %s" % (job["status"], job.get("error")))
        run = api.get("/api/runs?capture=%d" % job["id"])["runs"][0]
        sample = api.get("/api/runs/%d/samples" % run["id"])["samples"][0]
        stored = api.get("/api/samples/%d/draws?limit=1000" % sample["id"])
        by_pass = {}
        for d in sorted(stored["draws"], key=lambda d: d["rank"]):
            by_pass.setdefault(d["pass"], []).append(d)
        unnamed = next(d["name"].split(" \u00b7 ", 1)[1] for d in by_pass["scene"] if d["index"] == 2)
        for pass_name, ((want, want_rest), _) in expected_passes(unnamed).items():
            got = [{"index": d["index"], "name": d["name"], "count": d["count"], "bytes_read": d["bytes_read"],
                    "bytes_written": d["bytes_written"], "bytes": d["bytes"]} for d in by_pass.get(pass_name, [])]
            if got != want:
                failures.append("stored pass %s: draws %s, expected %s" % (pass_name, got[:4], want[:4]))
            rests = [r for r in stored["rest"] if r["pass"] == pass_name]
            if (want_rest is None) != (not rests) or (rests and rests[0]["draws"] != want_rest["draws"]):
                failures.append("stored pass %s: rest %s, expected %s" % (pass_name, rests, want_rest))
        env = dict(os.environ, TALLY_TOKEN="r3ad-0123456789abcdefghijklmnopqrstuv")
        p = subprocess.run([args.tally, "--server", api.base, "--json", "hotspots", str(run["id"]), "--by", "draw",
                            "--pass", "scene", "--top", "2"], env=env, capture_output=True, text=True, timeout=60)
        if p.returncode != 0:
            fail("tally hotspots exited %d: %s" % (p.returncode, p.stderr))
        top = json.loads(p.stdout)["passes"][0]["top"]
        want = expected_passes(unnamed)["scene"][0][0][:2]
        if [t["label"] for t in top] != ["#%d %s" % (d["index"], d["name"]) for d in want]:
            failures.append("tally hotspots --by draw: %s, expected the two heaviest %s" %
                            ([t["label"] for t in top], [d["name"] for d in want]))
    finally:
        daemon.terminate()
        daemon.wait(timeout=30)
    for f in failures:
        print("FAIL: " + f)
    if failures:
        sys.exit(1)
    print("draws: stored, served and ranked by tally hotspots as the layer counted them")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    parser.add_argument("--tallyd", required=True)
    parser.add_argument("--tally", required=True)
    parser.add_argument("--case", required=True, choices=["app", "capture"])
    args = parser.parse_args()
    args.build = os.path.abspath(args.build)
    if not os.path.exists(os.path.join(args.build, "layer", "VkLayer_tally_counters.json")):
        skip_or_fail("the layer is not built in %s" % args.build)
    with tempfile.TemporaryDirectory() as tmp:
        (case_app if args.case == "app" else case_capture)(args, tmp)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Early fragment tests kept through the layer (docs/layer.md, "What the
layer changes in the application"): depth_app.cpp draws opaque quads front
to back with depth LESS, in a pass whose fragment shader has no
early_fragment_tests but nothing that needs late tests ("early"), in one
whose shader may discard ("late"), and with the first shader in a pipeline
whose alpha to coverage is dynamic state, set off ("coverage-off": the
layer binds its early-tests twin) and on ("coverage-on": late tests, as
alpha to coverage needs).

  early_tests.py --build BUILD_DIR

The counts are derived from the quads (pixel centres inside each rectangle):
with early tests each pixel runs the shader of its front quad only, so the
"early" pass shades the pixels of the quads' union; late tests shade every
quad's pixels. The plain run measures each pass itself, with a precise
occlusion query (samples that passed the depth test: the fragments that run
with early tests) and a pipeline-statistics query. The layer's fragment
invocations of "early" and "coverage-off" must equal the union and the plain
run's occlusion count, and, on a device whose statistic counts shader
invocations (NVIDIA), the plain run's statistic; those of "late" and
"coverage-on" every quad's pixels. Lavapipe's statistic counts the fragments the
rasterizer generates before the depth test, in whole 4x4 blocks
(docs/measurement.md), so there it must be at least every quad's pixels and
the same with and without the layer.
"""
import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from strict import skip_or_fail  # noqa: E402

SIZE = 64  # depth_app's target, 64x64
# x0, y0, x1, y1 in pixels, depth; front to back. Overlapping, so early and late tests differ.
QUADS = [(8, 8, 40, 40, 0.25), (16, 4, 60, 48, 0.5), (0, 0, 64, 64, 0.75)]
FRAMES, SKIP = 2, 1
# depth_app's passes and whether each runs with early tests under the layer.
PASSES = {"early": True, "late": False, "coverage-off": True, "coverage-on": False}


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def covered(quad):
    x0, y0, x1, y1, _ = quad
    return {(x, y) for x in range(SIZE) for y in range(SIZE) if x0 < x + 0.5 < x1 and y0 < y + 0.5 < y1}


def derived():
    """Fragments shaded with early tests (each pixel once, by its front quad)
    and with late tests (every quad's pixels)."""
    seen, early, late = set(), 0, 0
    for quad in QUADS:
        pixels = covered(quad)
        early += len(pixels - seen)
        late += len(pixels)
        seen |= pixels
    return early, late


def run(command, env=None):
    result = subprocess.run(command, env=env, timeout=240, capture_output=True, text=True)
    if result.returncode != 0:
        fail("%s exited %d\n%s%s" % (" ".join(command), result.returncode, result.stdout[-2000:], result.stderr[-4000:]))
    return result


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    args = parser.parse_args()
    app = os.path.join(args.build, "tests", "layer", "tally_layer_depth_app")
    if not os.path.exists(app):
        skip_or_fail("no %s: build the tally_layer_depth_app target" % app)
    early, late = derived()
    if early >= late:
        fail("the quads do not overlap: early %d, late %d fragments cannot tell the tests apart" % (early, late))
    quads = ";".join(",".join(str(v) for v in q) for q in QUADS)
    command = [app, "--frames", str(FRAMES + SKIP), "--quads", quads]

    plain = {}
    for line in run(command + ["--queries", "1"]).stdout.splitlines():
        m = json.loads(line)
        plain.setdefault(m["pass"], []).append(m)
    if sorted(plain) != sorted(PASSES):
        fail("the plain run measured passes %s, expected %s" % (sorted(plain), sorted(PASSES)))
    for name, measures in plain.items():
        for m in measures:
            # The depth test keeps the front quad's fragments whatever the shader: the union, in both passes.
            if m["samples_passed"] != early:
                fail("plain %s frame %d: %d samples passed the depth test, derived %d" %
                     (name, m["frame"], m["samples_passed"], early))

    out = os.path.join(os.environ.get("TMPDIR", "/tmp"), "tally-early-tests-%d.json" % os.getpid())
    env = dict(os.environ)
    env.update({"VK_ADD_LAYER_PATH": os.path.join(args.build, "layer"),
                "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters", "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters",
                "TALLY_LAYER_OUTPUT": out, "TALLY_LAYER_FRAMES": str(FRAMES), "TALLY_LAYER_SKIP_FRAMES": str(SKIP),
                "TALLY_LAYER_STATISTICS_FRAMES": "all",
                "TALLY_LAYER_FRAME_SUBMITS": "1"})
    run(command + ["--queries", "0"], env=env)  # the application checks every pixel shows its front quad
    if not os.path.exists(out):
        fail("the layer wrote no output at " + out)
    with open(out) as f:
        result = json.load(f)
    os.remove(out)
    if not result["complete"] or len(result["frames"]) != FRAMES:
        fail("the layer's output holds %d frames, complete %s" % (len(result["frames"]), result["complete"]))
    refused = [s for s in result["shaders"] if not s["instrumented"]]
    if len(result["shaders"]) != 6 or refused:
        fail("expected 6 instrumented stages (3 pipelines): %s" % result["shaders"])
    notes = [n for n in result["notes"] if "early_fragment_tests" in n]
    if len(notes) != 1 or "cannot be given them (it discards" not in notes[0]:
        fail("expected one early-tests note, for the discarding shader: %s" % result["notes"])
    if not any("dynamic alpha to coverage runs its fragment shader with early tests" in n for n in result["notes"]):
        fail("no note on the pipeline with dynamic alpha to coverage: %s" % result["notes"])
    nvidia = result["device"]["vendorID"].lower() == "0x10de"

    for frame in result["frames"]:
        passes = {p["name"]: p for p in frame["passes"]}
        if sorted(passes) != sorted(PASSES):
            fail("frame %d: passes %s, expected %s" % (frame["index"], sorted(passes), sorted(PASSES)))
        for name, early_tests in PASSES.items():
            want = early if early_tests else late
            p, m = passes[name], plain[name][frame["index"]]
            counted = p["fragment_invocations"]
            if counted != want:
                fail("frame %d, %s: the layer counted %d fragment invocations, derived %d" %
                     (frame["index"], name, counted, want))
            writes = sum(r["count"] for r in p["resources"] if r["access"] == "write" and r["kind"] == "attachment")
            if writes != counted:
                fail("frame %d, %s: %d colour writes for %d invocations" % (frame["index"], name, writes, counted))
            stat = p.get("fragment_invocations_statistic", -1)
            # With early tests kept the instrumented pipeline shades what the plain one does. With late
            # tests it shades rejected fragments too, which only a statistic counted after the tests shows.
            if (early_tests or not nvidia) and stat != m["fragment_invocations_statistic"]:
                fail("frame %d, %s: statistic %d under the layer, %d plain" %
                     (frame["index"], name, stat, m["fragment_invocations_statistic"]))
            if nvidia and counted != stat:
                fail("frame %d, %s: the layer counted %d, its statistic is %d" % (frame["index"], name, counted, stat))
            if not nvidia and m["fragment_invocations_statistic"] < late:
                fail("frame %d, %s: statistic %d below the %d fragments rasterized" %
                     (frame["index"], name, m["fragment_invocations_statistic"], late))
            if early_tests and counted != m["samples_passed"]:
                fail("frame %d, %s: the layer counted %d, the plain occlusion query %d" %
                     (frame["index"], name, counted, m["samples_passed"]))
    first = {p["name"]: p for p in result["frames"][0]["passes"]}
    print("early tests: fragment invocations per frame %s; derived %d with early tests, %d with late; plain "
          "occlusion %d, plain statistic %d" %
          ({n: first[n]["fragment_invocations"] for n in PASSES}, early, late, plain["early"][0]["samples_passed"],
           plain["early"][0]["fragment_invocations_statistic"]))


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Descriptor buffers (VK_EXT_descriptor_buffer) under Tally's layer:
descriptor_buffer_app's draw and dispatch counted, every line named by the
resource whose descriptor the application wrote, and, where the Khronos
validation layer is installed, no message that only Tally's layer brings.

  descriptor_buffers_test.py --build BUILD_DIR [--out DIR]

Lavapipe 22.3 does not offer the extension: tests/gpu/descriptor_buffers.sh
runs this on the GPU machine. The expected counts come from the
application's own sizes (descriptor_buffer_app.cpp), never from a run.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
sys.path.insert(0, HERE)
from strict import skip_or_fail  # noqa: E402
import validation  # noqa: E402

NO_EXTENSION = 77  # descriptor_buffer_app's exit status without the extension
# descriptor_buffer_app.cpp: a 64x64 target covered once, one texel and one
# uint read per fragment; 8 groups of 64 invocations, one read and one write each.
FRAGMENTS = 64 * 64
INVOCATIONS = 8 * 64
EXPECTED = {
    "draw": {("texture", "read"): (FRAGMENTS, 4), ("lookup", "read"): (FRAGMENTS, 4),
             ("target", "write"): (FRAGMENTS, 4)},
    "double": {("input", "read"): (INVOCATIONS, 4), ("output", "write"): (INVOCATIONS, 4)},
}
FRAMES, SKIP = 2, 1


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def tally_env(frames=FRAMES, skip=SKIP):
    return {
        "TALLY_LAYER_FRAMES": str(frames),
        "TALLY_LAYER_SKIP_FRAMES": str(skip),
        "TALLY_LAYER_FRAME_SUBMITS": "1",
        "TALLY_LAYER_STATISTICS_FRAMES": "all",
    }


def check_pass(name, p):
    got = {}
    for r in p["resources"]:
        key = (r["name"], r["access"])
        count, size = got.get(key, (0, 0))
        got[key] = (count + r["count"], size + r["bytes"])
    want = {key: (count, count * width) for key, (count, width) in EXPECTED[name].items()}
    if got != want:
        fail("%s: lines %s, expected %s (a line named 'set S binding B' was not named from its descriptor)" %
             (name, sorted(got.items()), sorted(want.items())))


def check_output(out):
    if not out["complete"]:
        fail("the layer's output is incomplete: %d frames" % len(out["frames"]))
    if not out["layer"]["counting_enabled"]:
        fail("the layer did not count: %s" % out["layer"]["not_counting"])
    if out["layer"]["layouts_refused"] != 0:
        fail("%d pipeline layouts refused: %s" % (out["layer"]["layouts_refused"], out["notes"]))
    bad = [n for n in out["notes"] if "descriptor buffer" in n]
    if bad:
        fail("notes about descriptor buffers: %s" % bad)
    if [f["index"] for f in out["frames"]] != list(range(SKIP, SKIP + FRAMES)):
        fail("frames %s, expected %s" % ([f["index"] for f in out["frames"]], list(range(SKIP, SKIP + FRAMES))))
    for f in out["frames"]:
        passes = {p["name"]: p for p in f["passes"]}
        if set(passes) != set(EXPECTED):
            fail("frame %d: passes %s, expected %s" % (f["index"], sorted(passes), sorted(EXPECTED)))
        draw, double = passes["draw"], passes["double"]
        if draw["fragment_invocations"] != FRAGMENTS:
            fail("draw: %d fragments counted, expected %d" % (draw["fragment_invocations"], FRAGMENTS))
        # The statistic brackets the count: a device may count helper invocations in it.
        statistic = draw.get("fragment_invocations_statistic", -1)
        if statistic is not None and statistic >= 0 and statistic < FRAGMENTS:
            fail("draw: fragment statistic %d, below the %d fragments counted" % (statistic, FRAGMENTS))
        if double["compute_invocations"] != INVOCATIONS:
            fail("double: %d invocations counted, expected %d" % (double["compute_invocations"], INVOCATIONS))
        check_pass("draw", draw)
        check_pass("double", double)


def run_counted(app, layer_dir, folder):
    output = os.path.join(folder, "descriptor-buffers.json")
    env = dict(os.environ)
    env.update(tally_env())
    env.update({"VK_ADD_LAYER_PATH": layer_dir, "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters",
                "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters", "TALLY_LAYER_OUTPUT": output})
    p = subprocess.run([app, "--frames", str(SKIP + FRAMES + 1)], env=env, capture_output=True, text=True,
                       timeout=240)
    if p.returncode != 0:
        fail("descriptor_buffer_app under the layer exited %d\n%s%s" % (p.returncode, p.stdout, p.stderr[-4000:]))
    if not os.path.exists(output):
        fail("the layer wrote no output\n" + p.stderr[-4000:])
    with open(output) as f:
        out = json.load(f)
    check_output(out)
    print("counted: draw %d fragments (texture, lookup, target), double %d invocations (input, output), "
          "frames %d" % (FRAGMENTS, INVOCATIONS, FRAMES))


def run_validation(app, layer_dir, folder):
    if validation.manifest_folder(validation.VALIDATION) is None:
        skip_or_fail("the Khronos validation layer is not installed (Debian: vulkan-validationlayers)")
    try:
        found, _, first = validation.run_stacks([app, "--frames", str(SKIP + FRAMES + 1)], dict(os.environ), folder,
                                                layer_dir, tally_env())
    except validation.RunError as e:
        fail(str(e))
    extra = validation.defects(found)
    if extra:
        fail("messages only with Tally's layer: %s\n%s" %
             (extra, "\n".join(first[s][k] for k, stacks in extra.items() for s in stacks)))
    print("validation: %s" % validation.summary(found))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    parser.add_argument("--out", help="where the outputs and validation logs go (default: a temporary folder)")
    parser.add_argument("--validation", choices=["auto", "yes", "no"], default="auto",
                        help="auto: stack the Khronos validation layer where it is installed")
    args = parser.parse_args()
    app = os.path.abspath(os.path.join(args.build, "tests", "layer", "tally_layer_descriptor_buffer_app"))
    layer_dir = os.path.abspath(os.path.join(args.build, "layer"))
    plain = subprocess.run([app, "--frames", "2"], capture_output=True, text=True, timeout=120)
    if plain.returncode == NO_EXTENSION:
        skip_or_fail("the device offers no VK_EXT_descriptor_buffer: " + plain.stdout.strip())
    if plain.returncode != 0:
        fail("descriptor_buffer_app alone exited %d\n%s%s" % (plain.returncode, plain.stdout, plain.stderr[-4000:]))
    folder = args.out or tempfile.mkdtemp(prefix="tally-descriptor-buffers-")
    os.makedirs(folder, exist_ok=True)
    run_counted(app, layer_dir, folder)
    if args.validation == "yes" or (args.validation == "auto" and
                                    validation.manifest_folder(validation.VALIDATION) is not None):
        run_validation(app, layer_dir, folder)
    else:
        print("validation: not run (the Khronos validation layer is not installed)")


if __name__ == "__main__":
    main()

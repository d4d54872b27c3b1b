#!/usr/bin/env python3
"""OpenGL through Mesa's zink under the layer: glmark2's texture, build,
shading, terrain and shadow scenes on lavapipe, in a virtual X server.

  zink_test.py --build BUILD_DIR

zink lays out uniform blocks with a 4-byte array stride and enables
scalarBlockLayout and uniformBufferStandardLayout on its device: its modules
are valid there and not under the default rules. The layer validates for the
application's device (spirv::ValidationTarget), so every stage of every
pipeline must be instrumented, the target must name the layouts zink
enabled, and every scene's frames must be counted. zink sets alpha to
coverage at each draw (dynamic state): each pipeline is noted as having
early tests while it is off.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from strict import skip_or_fail  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from layer_test import glmark2_exited_well  # noqa: E402

# scene -> glmark2 seconds: enough for the skipped and counted frames (terrain's run ~1 s each instrumented).
SCENES = {"texture": 4, "build": 4, "shading": 4, "shadow": 5, "terrain": 12}
SKIP, FRAMES = 2, 2


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def start_x():
    read, write = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                            pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as f:
        display = f.readline().strip()
    if not display:
        xvfb.kill()
        fail("Xvfb did not start")
    return xvfb, ":" + display


def run_scene(build, scene, seconds, display, out):
    env = dict(os.environ)
    env.update({"DISPLAY": display, "LIBGL_ALWAYS_SOFTWARE": "1", "GALLIUM_DRIVER": "zink",
                "MESA_LOADER_DRIVER_OVERRIDE": "zink", "XDG_RUNTIME_DIR": tempfile.gettempdir(),
                "VK_ADD_LAYER_PATH": os.path.join(build, "layer"), "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters",
                "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters", "TALLY_LAYER_OUTPUT": out,
                "TALLY_LAYER_FRAMES": str(FRAMES), "TALLY_LAYER_SKIP_FRAMES": str(SKIP),
                "TALLY_LAYER_STATISTICS_FRAMES": "all"})
    result = subprocess.run(["glmark2", "-b", "%s:duration=%d" % (scene, seconds), "-s", "320x240"], env=env,
                            timeout=180, capture_output=True, text=True)
    if not glmark2_exited_well(result):
        fail("glmark2 %s exited %d: %s" % (scene, result.returncode, result.stderr[-2000:]))
    if not os.path.exists(out):
        fail("%s: the layer wrote no output (zink not in use?): %s" % (scene, result.stdout[-1000:]))
    with open(out) as f:
        return json.load(f)


def check(scene, result):
    if result["application"]["engine"] != "mesa zink":
        fail("%s: the Vulkan application is %r, not zink" % (scene, result["application"]["engine"]))
    target = result["layer"].get("spirv_validation", "")
    if "scalar block layout" not in target or "uniform buffer standard layout" not in target:
        fail("%s: the validation target %r does not name the layouts zink enables" % (scene, target))
    shaders = result["shaders"]
    refused = [s for s in shaders if not s["instrumented"]]
    if not shaders or refused:
        fail("%s: %d of %d stages refused: %s" % (scene, len(refused), len(shaders),
                                                  sorted({s["reason"][:200] for s in refused})))
    if not result["complete"] or len(result["frames"]) != FRAMES:
        fail("%s: %d frames read back, complete %s" % (scene, len(result["frames"]), result["complete"]))
    for frame in result["frames"]:
        drawn = [p for p in frame["passes"] if p["draws"] > 0]
        if not drawn or any(p["fragment_invocations"] <= 0 for p in drawn):
            fail("%s frame %d: a pass with draws counted no fragments: %s" %
                 (scene, frame["index"], [(p["name"], p["draws"], p["fragment_invocations"]) for p in drawn]))
    if not any("dynamic alpha to coverage runs its fragment shader with early tests" in n for n in result["notes"]):
        fail("%s: no early-tests twin noted for zink's dynamic alpha to coverage: %s" % (scene, result["notes"]))
    return len(shaders)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    args = parser.parse_args()
    for tool in ("glmark2", "Xvfb"):
        if shutil.which(tool) is None:
            skip_or_fail("%s is not installed (scripts/setup.sh installs it)" % tool)
    xvfb, display = start_x()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            stages = {}
            for scene, seconds in SCENES.items():
                stages[scene] = check(scene, run_scene(args.build, scene, seconds, display,
                                                        os.path.join(tmp, scene + ".json")))
    finally:
        xvfb.terminate()
        xvfb.wait(timeout=10)
    print("zink: every stage instrumented: %s" % ", ".join("%s %d" % kv for kv in stages.items()))


if __name__ == "__main__":
    main()

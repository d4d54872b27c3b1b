#!/usr/bin/env python3
"""Real clients of the Vulkan layer on lavapipe, each captured through
`tallyd capture` with an application spec and checked against counts
derived from the application's own source, never from the layer:

- OpenGL through Mesa's zink (OpenGL on Vulkan): glmark2's texture, build,
  shading, terrain and shadow scenes at 320x240 under Xvfb;
- ffmpeg's Vulkan compute filters, headless, a frame per submission:
  avgblur_vulkan and scale_vulkan on yuv420p 320x240 test frames;
- two of them stored and served through the daemon (`service`);
- glmark2's texture scene with per-site and per-draw counts, stored, served
  and ranked by `tally hotspots` (`sites`, clients_sites.py);

and every application also run under the Khronos validation layer alone,
then stacked with Tally's in both orders (validation.py): a message only a
stack with Tally's layer gives is the layer's defect, and fails the case.
vkcube and Tally's own renderers (`tallyd play`), whose counts
layer_test.py and compare_builtin.py check, get the validation runs only.

  clients_test.py --tallyd PATH --build BUILD_DIR --case NAME

Every relation of a case is checked and every failure printed, not only
the first.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from strict import skip_or_fail  # noqa: E402
import clients_relations as relations  # noqa: E402
import validation  # noqa: E402
from layer_test import glmark2_exited_well  # noqa: E402

W, H = 320, 240
# OpenGL through zink on lavapipe: software GL, the zink Gallium driver.
ZINK_ENV = {"LIBGL_ALWAYS_SOFTWARE": "1", "GALLIUM_DRIVER": "zink", "MESA_LOADER_DRIVER_OVERRIDE": "zink"}
SCENES = ["texture", "build", "shading", "terrain", "shadow"]
FILTERS = {
    # sizeX=1:sizeY=1 (a radius of 0), luma only: the other planes are copied.
    "avgblur": "avgblur_vulkan=sizeX=1:sizeY=1:planes=1",
    "scale": "scale_vulkan=w=%d:h=%d" % (W // 2, H // 2),
}
# Tally's own renderers under validation: the forward default, subpasses
# with input attachments, compute shading, and MSAA with a bloom chain.
PLAY = [("forward", None), ("deferred", {"gbuffer": "subpass"}), ("deferred", {"shading": "compute"}),
        ("visbuffer", {"msaa": 4, "bloom": "separable"})]
SKIP, FRAMES = 5, 3  # glmark2: frames to let pass (zink compiles its pipelines), frames counted
FFMPEG_SKIP, FFMPEG_FRAMES, FFMPEG_INPUT = 2, 3, 8


class Failures:
    def __init__(self, case):
        self.case, self.items, self.prefix = case, [], ""

    def check(self, condition, message):
        if not condition:
            self.items.append(self.prefix + message)
        return condition

    def finish(self, passed):
        if self.items:
            for m in self.items:
                print("FAIL: %s: %s" % (self.case, m))
            sys.exit(1)
        print("%s: %s" % (self.case, passed))


def glmark2_command(scene, seconds):
    return ["glmark2", "-b", "%s:duration=%d" % (scene, seconds), "-s", "%dx%d" % (W, H)]


def ffmpeg_command(name, frames):
    chain = "format=yuv420p,hwupload,%s,hwdownload,format=yuv420p" % FILTERS[name]
    return ["ffmpeg", "-hide_banner", "-nostdin", "-loglevel", "error", "-init_hw_device", "vulkan=vk:0",
            "-filter_hw_device", "vk", "-f", "lavfi", "-i", "testsrc=size=%dx%d:rate=10" % (W, H),
            "-frames:v", str(frames), "-vf", chain, "-f", "null", "-"]


def glmark2_spec(scene):
    # glmark2 runs a scene for a time, not a number of frames: long enough
    # for the frames on a loaded machine; tallyd stops it once they are in.
    return {"application": {"command": glmark2_command(scene, 60), "frames": FRAMES, "skip_frames": SKIP,
                            "display": "xvfb", "env": dict(ZINK_ENV), "timeout_s": 120}}


def ffmpeg_spec(name):
    return {"application": {"command": ffmpeg_command(name, FFMPEG_INPUT), "frames": FFMPEG_FRAMES,
                            "skip_frames": FFMPEG_SKIP, "frame_submits": 1, "timeout_s": 120}}


def capture(tallyd, spec, tmp, failures):
    """The run `tallyd capture` stores for the spec, or None (failed)."""
    spec_path, out = os.path.join(tmp, "spec.json"), os.path.join(tmp, "result.json")
    with open(spec_path, "w") as f:
        json.dump(spec, f)
    p = subprocess.run([tallyd, "capture", "--spec", spec_path, "--out", out, "--quiet"],
                       capture_output=True, text=True, timeout=300)
    if not failures.check(p.returncode == 0 and os.path.exists(out),
                          "tallyd capture exited %d: %s" % (p.returncode, p.stderr[-3000:])):
        return None
    with open(out) as f:
        return json.load(f)["runs"][0]


def runtime_dir(tmp):
    """A private XDG_RUNTIME_DIR: Mesa's X11 code complains without one."""
    path = os.path.join(tmp, "xdg")
    os.makedirs(path, mode=0o700, exist_ok=True)
    return path


class Xvfb:
    """An X server for the direct runs, started without the layer's
    variables (it loads Mesa too), on the first free display."""

    def __enter__(self):
        read, write = os.pipe()
        self.process = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x1024x24",
                                         "-nolisten", "tcp"], pass_fds=(write,), stderr=subprocess.DEVNULL)
        os.close(write)
        with os.fdopen(read) as f:
            number = f.readline().strip()
        if not number:
            self.process.wait(timeout=30)
            print("FAIL: Xvfb did not start (exit %s)" % self.process.returncode)
            sys.exit(1)
        self.display = ":" + number
        return self

    def __exit__(self, *exc):
        self.process.terminate()
        self.process.wait(timeout=30)


def exited_well(p):
    return p.returncode == 0


def validation_runs(failures, command, env, tmp, tally_dir, frame_submits=0, check=None, ended=exited_well):
    """The command under validation alone and stacked with Tally's layer both
    ways; fails the case for every message only Tally's presence gives.
    `check(stack, process)` looks at each run's own output; `ended(process)`
    says whether the application ended as it should."""
    folder = os.path.join(tmp, "validation")
    os.makedirs(folder, exist_ok=True)
    tally_env = {"TALLY_LAYER_FRAMES": "100000", "TALLY_LAYER_SKIP_FRAMES": "0",
                 "TALLY_LAYER_FRAME_SUBMITS": str(frame_submits), "TALLY_LAYER_STATISTICS_FRAMES": "all"}
    try:
        found, processes, first = validation.run_stacks(command, env, folder, tally_dir, tally_env)
    except (validation.RunError, subprocess.TimeoutExpired) as e:
        failures.check(False, "validation runs: %s" % e)
        return
    for stack, p in processes.items():
        failures.check(ended(p), "%s: %s exited %d\n%s" %
                       (stack, command[0], p.returncode, validation.tail(p.stderr)))
        if check:
            check(stack, p)
    for key, counts in sorted(validation.defects(found).items()):
        stack = sorted(counts)[0]
        failures.check(False, "validation message %s only with Tally's layer (%s); first: %s" %
                       (key, ", ".join("%s: %d" % item for item in sorted(counts.items())), first[stack][key]))
    print(validation.summary(found))


def case_glmark2(args, scene, tmp):
    failures = Failures("glmark2 " + scene)
    spec = glmark2_spec(scene)
    spec["application"]["env"]["XDG_RUNTIME_DIR"] = runtime_dir(tmp)
    run = capture(args.tallyd, spec, tmp, failures)
    if run is not None:
        relations.glmark2_common(run, failures, W, H, SKIP, FRAMES)
        relations.GLMARK2[scene](run, failures, W, H)

    def renderer_is_zink(stack, p):
        failures.check("GL_RENDERER:    zink (" in p.stdout,
                       "%s: glmark2's GL renderer is not zink: %s" %
                       (stack, [line for line in p.stdout.splitlines() if "GL_RENDERER" in line]))

    with Xvfb() as x:
        env = dict(os.environ, DISPLAY=x.display, XDG_RUNTIME_DIR=runtime_dir(tmp), **ZINK_ENV)
        validation_runs(failures, glmark2_command(scene, 1), env, tmp, args.layer_dir, check=renderer_is_zink,
                        ended=glmark2_exited_well)
    failures.finish("relations hold over %d frames; no validation message of Tally's" % FRAMES)


def case_ffmpeg(args, name, tmp):
    failures = Failures("ffmpeg " + name)
    run = capture(args.tallyd, ffmpeg_spec(name), tmp, failures)
    if run is not None:
        relations.ffmpeg_common(run, failures, FFMPEG_SKIP, FFMPEG_FRAMES)
        relations.FFMPEG[name](run, failures, W, H)
    validation_runs(failures, ffmpeg_command(name, FFMPEG_INPUT), dict(os.environ), tmp, args.layer_dir,
                    frame_submits=1)
    failures.finish("relations hold over %d frames; no validation message of Tally's" % FFMPEG_FRAMES)


def case_vkcube(args, tmp):
    failures = Failures("vkcube")
    with Xvfb() as x:
        validation_runs(failures, ["vkcube", "--c", "20"], dict(os.environ, DISPLAY=x.display), tmp, args.layer_dir)
    failures.finish("no validation message of Tally's")


def case_play(args, tmp):
    """Tally's renderers as plain applications: their own validation
    messages (there are some) must be the same with Tally's layer."""
    failures = Failures("tallyd play")
    for i, (renderer, options) in enumerate(PLAY):
        command = [args.tallyd, "play", "--renderer", renderer, "--scene", "planes", "--resolution", "96x54",
                   "--frames", "3", "--quiet"] + (["--options", json.dumps(options)] if options else [])
        folder = os.path.join(tmp, str(i))
        os.makedirs(folder)
        failures.prefix = "%s %s: " % (renderer, json.dumps(options) if options else "")
        print(failures.prefix)
        validation_runs(failures, command, dict(os.environ), folder, args.layer_dir, frame_submits=1)
    failures.finish("%d renderers: no validation message of Tally's" % len(PLAY))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--tallyd", required=True)
    parser.add_argument("--build", required=True)
    parser.add_argument("--case", required=True)
    args = parser.parse_args()
    args.tallyd = os.path.abspath(args.tallyd)
    args.layer_dir = os.path.join(os.path.abspath(args.build), "layer")
    needs = {"glmark2": ["glmark2", "Xvfb"], "ffmpeg": ["ffmpeg"], "vkcube": ["vkcube", "Xvfb"], "play": [],
             "service": ["glmark2", "ffmpeg"], "sites": ["glmark2"]}[args.case.split("-")[0]]
    for tool in needs:
        if shutil.which(tool) is None:
            skip_or_fail(tool + " is not installed (scripts/setup.sh installs glmark2-x11, ffmpeg, xvfb, vulkan-tools)")
    if validation.manifest_folder(validation.VALIDATION) is None and args.case not in ("service", "sites"):
        skip_or_fail("the Khronos validation layer is not installed (scripts/setup.sh: vulkan-validationlayers)")
    with tempfile.TemporaryDirectory(prefix="tally-clients-") as tmp:
        kind, _, name = args.case.partition("-")
        if kind == "glmark2" and name in SCENES:
            case_glmark2(args, name, tmp)
        elif kind == "ffmpeg" and name in FILTERS:
            case_ffmpeg(args, name, tmp)
        elif args.case == "vkcube":
            case_vkcube(args, tmp)
        elif args.case == "play":
            case_play(args, tmp)
        elif args.case == "service":
            import clients_service
            clients_service.run(args, tmp, glmark2_spec("texture"), ffmpeg_spec("avgblur"), Failures("service"))
        elif args.case == "sites":
            import clients_sites
            clients_sites.run(args, tmp, glmark2_spec("texture"), Failures("glmark2 texture, sites"))
        else:
            parser.error("unknown case " + args.case)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""What the Vulkan layer costs an application outside its counted window, and
inside it: glmark2's texture scene through zink on lavapipe, run plain and
under the layer four ways, interleaved round by round so that the machine's
load drifts over every mode alike. Prints figures; asserts nothing
(docs/benchmarks.md, "The Vulkan layer's cost").

  layer_fps.py --layer-dir BUILD/layer [--rounds 5] [--duration 3] [--size 320x240]
               [--scene texture] [--tallyd BUILD/server/tallyd] [--glmark2-data DIR]

Modes:
  plain      no layer
  no-output  the layer loaded, TALLY_LAYER_OUTPUT unset
  skipping   an output asked for, the run ends before skip_frames does
  counting   an output asked for, every frame after the first 100 counted
Each round runs every mode once; a ratio is a mode's FPS over the plain run of
the same round. Beside FPS, the CPU time glmark2 used per frame it drew
(start-up included): on a machine shared with other work, FPS follows the
load and CPU time much less. Then one counting run of the scenes in --pipeline-scenes
gives the pipelines' creation time as the layer measures it: the
application's own pipelines, and their instrumented twins (instrumentation
included). With --tallyd, `tallyd play` (planes, forward, 320x180) is
timed the same way, plain against the layer with skip_frames beyond its end.
"""
import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time

FPS = re.compile(r"\[(\w+)\][^\n]*FPS: (\d+)")


def start_xvfb():
    """An X server on the first free display, started without the layer's
    variables (Xvfb loads Mesa too)."""
    read, write = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                              pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    display = b""
    while not display.endswith(b"\n"):
        chunk = os.read(read, 16)
        if not chunk:
            sys.exit("layer_fps: Xvfb did not start")
        display += chunk
    os.close(read)
    return server, ":" + display.decode().strip()


def layer_env(layer_dir, tmp, mode):
    env = {"VK_ADD_LAYER_PATH": layer_dir, "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters",
           "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters"}
    if mode == "skipping":
        env.update({"TALLY_LAYER_OUTPUT": os.path.join(tmp, "skipping.json"), "TALLY_LAYER_SKIP_FRAMES": "10000000"})
    elif mode == "counting":
        env.update({"TALLY_LAYER_OUTPUT": os.path.join(tmp, "counting.json"), "TALLY_LAYER_SKIP_FRAMES": "100",
                    "TALLY_LAYER_FRAMES": "100000"})
    return env


def children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def glmark2(args, display, extra, scenes=None):
    """FPS of the first scene and CPU milliseconds per frame of the run."""
    env = dict(os.environ)
    for key in [k for k in env if k.startswith("TALLY_LAYER_") or "LAYER" in k and k.startswith("VK_")]:
        del env[key]
    env.update({"LIBGL_ALWAYS_SOFTWARE": "1", "GALLIUM_DRIVER": "zink", "MESA_LOADER_DRIVER_OVERRIDE": "zink",
                "XDG_RUNTIME_DIR": tempfile.gettempdir(), "DISPLAY": display})
    env.update(extra)
    command = ["glmark2", "-s", args.size] + (["--data-path", args.glmark2_data] if args.glmark2_data else [])
    for scene in scenes or [args.scene]:
        command += ["-b", "%s:duration=%g" % (scene, args.duration)]
    cpu = children_cpu()
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=120 + args.duration * 4)
    cpu = children_cpu() - cpu
    match = FPS.search(result.stdout)
    if result.returncode != 0 or match is None:
        sys.exit("layer_fps: glmark2 failed (%d): %s%s" % (result.returncode, result.stdout[-800:], result.stderr[-800:]))
    fps = int(match.group(2))
    return fps, 1000.0 * cpu / max(fps * args.duration, 1)


def play(args, extra, tmp):
    """`tallyd play`'s whole run: wall and CPU seconds."""
    env = dict(os.environ)
    env.update(extra)
    command = [args.tallyd, "play", "--renderer", "forward", "--scene", "planes", "--resolution", "320x180",
               "--frames", str(args.play_frames)]
    start, cpu = time.monotonic(), children_cpu()
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)
    seconds, cpu = time.monotonic() - start, children_cpu() - cpu
    if result.returncode != 0:
        sys.exit("layer_fps: tallyd play failed: " + result.stderr[-800:])
    return seconds, cpu


def summary(name, runs, plain):
    fps, cpu = [r[0] for r in runs], [r[1] for r in runs]
    ratios = [r[0] / p[0] for r, p in zip(runs, plain)]
    cpu_ratios = [r[1] / p[1] for r, p in zip(runs, plain)]
    return ("%-10s FPS median %6.0f (%s); FPS / plain's: median %.3f, min %.3f, max %.3f; "
            "CPU ms a frame median %.3f, / plain's %.3f") % (
        name, statistics.median(fps), " ".join(str(v) for v in fps), statistics.median(ratios), min(ratios),
        max(ratios), statistics.median(cpu), statistics.median(cpu_ratios))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--layer-dir", required=True)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--duration", type=float, default=3)
    parser.add_argument("--size", default="320x240")
    parser.add_argument("--scene", default="texture")
    parser.add_argument("--tallyd", help="also time `tallyd play` plain and under the layer outside its window")
    parser.add_argument("--play-frames", type=int, default=5, help="frames of each tallyd play run (lavapipe: 2.4 s each)")
    parser.add_argument("--glmark2-data", help="glmark2's models, shaders and textures, where not installed")
    parser.add_argument("--pipeline-scenes", default="texture,build,shading,terrain,shadow")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    layer_dir = os.path.abspath(args.layer_dir)
    modes = ["plain", "no-output", "skipping", "counting"]
    fps = {m: [] for m in modes}
    server, display = start_xvfb()
    try:
        with tempfile.TemporaryDirectory(prefix="tally-layer-fps-") as tmp:
            for r in range(args.rounds):
                for m in modes:
                    fps[m].append(glmark2(args, display, {} if m == "plain" else layer_env(layer_dir, tmp, m)))
                print("round %d: %s" % (r + 1, ", ".join("%s %d FPS %.3f CPU ms" % (m, *fps[m][-1]) for m in modes)),
                      flush=True)
            glmark2(args, display, layer_env(layer_dir, tmp, "counting"), args.pipeline_scenes.split(","))
            counted = json.load(open(os.path.join(tmp, "counting.json")))
            play_times = None
            if args.tallyd:
                play_times = {"plain": [], "skipping": []}
                for r in range(args.rounds):
                    play_times["plain"].append(play(args, {}, tmp))
                    extra = layer_env(layer_dir, tmp, "skipping")
                    extra["TALLY_LAYER_FRAME_SUBMITS"] = "1"
                    play_times["skipping"].append(play(args, extra, tmp))
    finally:
        server.terminate()
        server.wait()
    print("\nglmark2 %s %s, %d rounds of %g s, zink on lavapipe" % (args.scene, args.size, args.rounds, args.duration))
    for m in modes:
        print(summary(m, fps[m], fps["plain"]))
    creation = counted["layer"].get("pipeline_creation_ms", {"application": float("nan"), "instrumented": float("nan")})
    print("pipeline creation (glmark2 %s, counting): %d pipelines, %d instrumented; the application's %.1f ms, "
          "the instrumented twins %.1f ms (instrumentation included)" %
          (args.pipeline_scenes, counted["layer"]["pipelines"], counted["layer"]["pipelines_counted"],
           creation["application"], creation["instrumented"]))
    if play_times:
        print("\ntallyd play forward planes 320x180, %d frames a run (wall s, CPU s)" % args.play_frames)
        for m, runs in play_times.items():
            print("%-10s %s" % (m, "  ".join("%.2f, %.2f" % t for t in runs)))
        for i, what in ((0, "wall"), (1, "CPU")):
            ratios = [p[i] / s[i] for p, s in zip(play_times["plain"], play_times["skipping"])]
            print("%s time plain / under the layer before its window: median %.3f" % (what, statistics.median(ratios)))
    if args.json:
        print(json.dumps({"fps": fps, "pipeline_creation_ms": creation}))


if __name__ == "__main__":
    main()

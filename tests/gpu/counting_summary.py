#!/usr/bin/env python3
"""The cost of counting, by renderer (or variant), pass and counting mode,
from capture results: the median over a run's samples of the overhead ratio
(counted frame or pass time over the uninstrumented one of the same run).
Prints Markdown tables: frames, then the frames' host wall time beside
their GPU time (where the results carry it), then passes.

  counting_summary.py RESULT.json [RESULT.json ...]
"""
import json
import statistics
import sys
from collections import OrderedDict


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def fmt(v):
    return "-" if v is None else f"x{v:.3f}"


frames = OrderedDict()  # (label, scene, size) -> {mode: ratio}
walls = OrderedDict()  # (label, scene, size, mode) -> (gpu ms, counted gpu ms, wall ms, counted wall ms)
passes = OrderedDict()  # (label, scene, size, pass) -> {mode: ratio}
modes = []
for path in sys.argv[1:]:
    result = json.load(open(path))
    for run in result["runs"]:
        label = run.get("variant") or run["renderer"]
        key = (label, run["scene"], f'{run["width"]}x{run["height"]}')
        mode = run.get("counting", "exact")
        if mode not in modes:
            modes.append(mode)
        frames.setdefault(key, {})[mode] = median(s.get("overhead_ratio") for s in run["samples"])
        # Host wall time of a frame (recording, submitting, waiting for the
        # GPU: extras.frame_wall_ms), medians over the samples.
        samples = run["samples"]
        wall = median(s.get("extras", {}).get("frame_wall_ms") for s in samples)
        if wall is not None:
            walls[key + (mode,)] = (median(s.get("frame_ms") for s in samples),
                                    median(s.get("frame_ms_instrumented") for s in samples), wall,
                                    median(s.get("extras", {}).get("frame_wall_ms_instrumented") for s in samples))
        names = [p["name"] for p in run["samples"][0]["passes"]] if run["samples"] else []
        for name in names:
            ratios = [p.get("overhead_ratio") for s in run["samples"] for p in s["passes"] if p["name"] == name]
            passes.setdefault(key + (name,), {})[mode] = median(ratios)

print("| renderer | scene | size | " + " | ".join(modes) + " |")
print("|---|---|---|" + "---|" * len(modes))
for (label, scene, size), by in frames.items():
    print(f"| {label} | {scene} | {size} | " + " | ".join(fmt(by.get(m)) for m in modes) + " |")
if walls:
    def ms(v):
        return "-" if v is None else f"{v:.3f}"

    def ratio(a, b):
        return "-" if a is None or not b else f"x{a / b:.3f}"

    print()
    print("| renderer | mode | GPU ms plain | GPU ms counted | GPU ratio | wall ms plain | wall ms counted | wall ratio |")
    print("|---|---|---|---|---|---|---|---|")
    for (label, scene, size, mode), (gpu, gpuCounted, wall, wallCounted) in walls.items():
        print(f"| {label} | {mode} | {ms(gpu)} | {ms(gpuCounted)} | {ratio(gpuCounted, gpu)} | {ms(wall)} | "
              f"{ms(wallCounted)} | {ratio(wallCounted, wall)} |")
print()
print("| renderer | pass | " + " | ".join(modes) + " |")
print("|---|---|" + "---|" * len(modes))
for (label, scene, size, name), by in passes.items():
    print(f"| {label} | {name} | " + " | ".join(fmt(by.get(m)) for m in modes) + " |")

# The compiled code's cost, where the driver reports it: per pass and stage,
# the plain pipeline's figure and the counted one's in each mode.
KEYS = ("register", "occupancy", "local", "spill", "shared", "warps", "threads")
code = OrderedDict()  # (label, pass, stages, statistic) -> {"plain": v, mode: v}
for path in sys.argv[1:]:
    for run in json.load(open(path))["runs"]:
        stats = run.get("pipeline_statistics")
        if not stats:
            continue
        label = run.get("variant") or run["renderer"]
        mode = run.get("counting", "exact")
        for which, column in (("plain", "plain"), ("instrumented", mode)):
            for e in stats.get(which, []):
                for name, v in e["statistics"].items():
                    # NVIDIA reports 2^36 as the local memory size of every
                    # pipeline on driver 580, whatever the shader: not a size.
                    if v >= 2 ** 36:
                        continue
                    if any(k in name.lower() for k in KEYS):
                        row = code.setdefault((label, e["pass"], e["stages"], name), {})
                        row[column] = max(row.get(column, v), v)
if code:
    print()
    print("| renderer | pass | stages | statistic | plain | " + " | ".join(modes) + " |")
    print("|---|---|---|---|---|" + "---|" * len(modes))
    for (label, name, stages, stat), by in code.items():
        cells = [by.get("plain")] + [by.get(m) for m in modes]
        print(f"| {label} | {name} | {stages} | {stat} | " + " | ".join("-" if c is None else f"{c:g}" for c in cells) + " |")

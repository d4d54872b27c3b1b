#!/usr/bin/env python3
"""Summarises tests/gpu/layer.sh's files: the layer against the built-in
instrumentation on Sponza (lines equal, the layer's frame time against the
plain and the built-in counted frame), and vkcube and its replay under the
layer (counts per frame, frame for frame).

  layer_summary.py OUT_DIR
"""
import gzip
import json
import os
import sys


def load(path):
    if not os.path.exists(path):
        return None
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt") as f:
        return json.load(f)


def main():
    out = sys.argv[1]
    sponza = load(os.path.join(out, "layer-sponza.json"))
    if sponza:
        print("Sponza %dx%d, camera 0: tallyd play under the layer against tallyd capture (exact)" %
              tuple(sponza["resolution"]))
        print("%-18s %7s %7s %11s %11s %11s %9s %9s" % ("renderer", "equal", "differ", "plain ms", "layer ms",
                                                        "built-in ms", "layer x", "built-in x"))
        for r in sponza["renderers"]:
            plain, lay, counted = r["frame_ms_plain"], r["frame_ms_layer_median"], r["frame_ms_builtin_counted"]
            differ = len(r["mismatched"]) + len(r["only_builtin"]) + len(r["only_layer"])
            print("%-18s %7d %7d %11.3f %11.3f %11s %9.3f %9s" % (
                r["renderer"], r["lines_equal"], differ, plain, lay,
                "%.3f" % counted if counted else "-", lay / plain if plain else float("nan"),
                "%.3f" % (counted / plain) if counted and plain else "-"))
    for name in ("vkcube.json.gz", "replay.json.gz", "vkcube-headless.json.gz"):
        result = load(os.path.join(out, name))
        if not result:
            print("%s: none" % name)
            continue
        rows = []
        for f in result["frames"]:
            p = f["passes"][0]
            tex = sum(r["count"] for r in p["resources"] if r["kind"] == "texture")
            rows.append((f["index"], p["fragment_invocations"], tex, p["fragment_invocations_statistic"], p["gpu_ms"]))
        ok = all(t == fi for _, fi, t, _, _ in rows)
        print("%s on %s: %d frames; texture reads %s fragment invocations; statistic/counted %.4f..%.4f; "
              "pass %.4f..%.4f ms" % (name.split(".")[0], result["device"]["name"], len(rows),
                                      "=" if ok else "!=",
                                      min(s / fi for _, fi, _, s, _ in rows), max(s / fi for _, fi, _, s, _ in rows),
                                      min(r[4] for r in rows), max(r[4] for r in rows)))
    a, b = load(os.path.join(out, "play-live.json.gz")), load(os.path.join(out, "play-replay.json.gz"))
    if a and b:
        def lines(frame):
            return {(p["name"], r["name"], r["access"], r["source"]): r["count"] for p in frame["passes"] for r in p["resources"]}
        same = sum(lines(x) == lines(y) for x, y in zip(a["frames"], b["frames"]))
        print("tallyd play (live, under the layer) against its GFXReconstruct replay under the layer: %d of %d frames "
              "with every line equal (%d lines a frame); frame ms live %.3f, replay %.3f (medians)" % (
                  same, min(len(a["frames"]), len(b["frames"])), len(lines(a["frames"][0])),
                  sorted(f["frame_ms"] for f in a["frames"])[len(a["frames"]) // 2],
                  sorted(f["frame_ms"] for f in b["frames"])[len(b["frames"]) // 2]))
    live, replay = load(os.path.join(out, "vkcube.json.gz")), load(os.path.join(out, "replay.json.gz"))
    if live and replay:
        a = {f["index"]: f["passes"][0]["fragment_invocations"] for f in live["frames"]}
        b = {f["index"]: f["passes"][0]["fragment_invocations"] for f in replay["frames"]}
        common = sorted(a.keys() & b.keys())
        same = sum(a[i] == b[i] for i in common)
        print("replay against live: %d of %d common frames with equal fragment invocations" % (same, len(common)))


if __name__ == "__main__":
    main()

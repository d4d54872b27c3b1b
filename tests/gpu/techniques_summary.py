#!/usr/bin/env python3
"""Per-variant summary of a capture result (tests/gpu/techniques.sh).

One row per run (variant x scene x resolution x counting mode), medians over
the run's samples (cameras): uninstrumented frame time, the time of each pass
that differs between variants, bytes per frame (immediate model; the
tile-memory model where present), image error against the reference variant
(variant_error) and against forward (image_error), then the technique extras
of the first sample in compact JSON.

    techniques_summary.py RESULT.json [--passes]
"""
import json
import statistics
import sys


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def fmt(v, digits=3):
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def psnr(error):
    if not error:
        return None
    return "identical" if error.get("identical") else error.get("psnr")


def scene_name(run):
    s = run.get("scene", "")
    return s.rsplit("/", 1)[-1]


def compact(extras, limit=400):
    text = json.dumps(extras, separators=(",", ":"), sort_keys=True)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def main():
    result = json.load(open(sys.argv[1]))
    show_passes = "--passes" in sys.argv
    print("device:", result.get("device", {}).get("name"), " driver:", result.get("device", {}).get("driverInfo"))
    header = ["variant", "scene", "res", "frame_ms", "frame_ms_instr", "bytes/frame", "bytes_tile", "variant_psnr",
              "vs_forward_psnr", "passes (ms)"]
    print("\t".join(header))
    for run in result.get("runs", []):
        samples = run.get("samples", [])
        if not samples:
            continue
        pass_ms = {}
        for s in samples:
            for p in s.get("passes", []):
                pass_ms.setdefault(p["name"], []).append(p.get("gpu_ms"))
        passes = " ".join(f"{n}={fmt(median(v))}" for n, v in pass_ms.items())
        vpsnr = [psnr(s.get("variant_error")) for s in samples]
        fpsnr = [psnr(s.get("image_error")) for s in samples]

        def worst(values):
            nums = [v for v in values if isinstance(v, (int, float))]
            if nums:
                return fmt(min(nums), 1)
            return "identical" if any(v == "identical" for v in values) else "-"

        row = [run.get("variant", run.get("renderer")), scene_name(run), f"{run['width']}x{run['height']}",
               fmt(median([s.get("frame_ms") for s in samples])),
               fmt(median([s.get("frame_ms_instrumented") for s in samples])),
               fmt(median([s.get("bytes") for s in samples]), 0),
               fmt(median([s.get("bytes_tile_model") for s in samples]), 0),
               worst(vpsnr), worst(fpsnr), passes]
        print("\t".join(str(c) for c in row))
    print()
    print("extras (first sample of each run):")
    for run in result.get("runs", []):
        samples = run.get("samples", [])
        if samples and samples[0].get("extras"):
            print(f"  {run.get('variant')} {scene_name(run)} {run['width']}x{run['height']}: {compact(samples[0]['extras'])}")
    if show_passes:
        print()
        for run in result.get("runs", []):
            for s in run.get("samples", [])[:1]:
                for p in s.get("passes", []):
                    for r in p.get("resources", []):
                        print(f"  {run.get('variant')}\t{p['name']}\t{r['name']}\t{r['access']}\t{r['count']}\t{r['bytes']}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Rewrites a capture or sweep spec for a GPU run and prints it as JSON.

The GPU scripts (accuracy.sh, repeats.sh, protocol.sh, sweeps.sh,
techniques.sh) all shrink or redirect their checked-in specs the same way:

  spec_edit.py SPEC [--resolution WxH] [--frames N] [--sponza PATH]
               [--scene NAME [--cameras N]] [--counting MODE,MODE...]
               [--renderers NAME,NAME...]

  --resolution  a sweep's "resolution", or a capture's "resolutions" (one entry)
  --frames      a capture's "frames"
  --sponza      every scene "SPONZA" (a name, or a {"gltf": "SPONZA"} path)
                becomes {"gltf": PATH}
  --scene       the capture's one scene (SPONZA for Sponza); where the spec has
                no "cameras", the first N (--cameras, default 2) of
                tests/gpu/accuracy-<scene>.json, which frame that scene
  --counting    a capture's "counting" modes, comma-separated
  --renderers   keep only these of a capture's "renderers" and "workloads"
                (names, comma-separated); the others are left out
"""
import argparse
import json
import sys


def resolution(text):
    try:
        w, h = text.lower().split("x")
        return [int(w), int(h)]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be WxH, got '{text}'")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("spec")
    ap.add_argument("--resolution", type=resolution)
    ap.add_argument("--frames", type=int)
    ap.add_argument("--sponza")
    ap.add_argument("--scene")
    ap.add_argument("--cameras", type=int, default=2)
    ap.add_argument("--counting", help="comma-separated counting modes")
    ap.add_argument("--renderers", help="comma-separated renderer and workload names to keep")
    ap.add_argument("--sites", action="store_true", help="count per access site (the spec's \"sites\")")
    ap.add_argument("--footprint", type=int, help="footprint block bytes (the spec's \"footprint\")")
    args = ap.parse_args()

    with open(args.spec) as f:
        spec = json.load(f)
    if args.scene:
        spec["scenes"] = [args.scene]
        if "cameras" not in spec:
            with open(f"tests/gpu/accuracy-{args.scene.lower()}.json") as f:
                spec["cameras"] = json.load(f)["cameras"][: args.cameras]
    if args.sponza and "scenes" in spec:
        def sponza(scene):
            named = scene == "SPONZA" or (isinstance(scene, dict) and scene.get("gltf") == "SPONZA")
            return {"gltf": args.sponza} if named else scene
        spec["scenes"] = [sponza(s) for s in spec["scenes"]]
    if args.resolution:
        if "sweep" in spec:
            spec["resolution"] = args.resolution
        else:
            spec["resolutions"] = [args.resolution]
    if args.counting:
        spec["counting"] = [m for m in args.counting.split(",") if m]
    if args.renderers:
        keep = {n for n in args.renderers.split(",") if n}
        def named(entry, key):
            return entry if isinstance(entry, str) else entry.get(key)
        for key, field in (("renderers", "renderer"), ("workloads", "workload")):
            if key in spec:
                spec[key] = [e for e in spec[key] if named(e, field) in keep]
                if not spec[key]:
                    del spec[key]
        if not spec.get("renderers") and not spec.get("workloads"):
            sys.exit(f"--renderers {args.renderers}: the spec has none of these")
    if args.sites:
        spec["sites"] = True
    if args.footprint:
        spec["footprint"] = args.footprint
    if args.frames:
        # A spec that counts every frame keeps doing so; one that counts
        # fewer keeps its count, within the new frames.
        counted = spec.get("counted_frames")
        if counted is not None and (counted >= spec.get("frames", 20) or counted > args.frames):
            spec["counted_frames"] = args.frames
        spec["frames"] = args.frames
    json.dump(spec, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()

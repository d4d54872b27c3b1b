#!/usr/bin/env python3
"""Tally's own renderers, run as an ordinary uninstrumented application
(`tallyd play`) under the Vulkan layer, must give the per-pass, per-resource
counts of their built-in instrumentation (`tallyd capture`, exact): every
counted line, by pass and resource name, equal, and of the same kind (both
sides name a line's kind by its use: a G-buffer target sampled is a
"texture", an image written by imageStore a "storage image").

  compare_builtin.py --tallyd PATH --layer-dir DIR --scene NAME_OR_JSON
                     [--renderers a,b] [--resolution WxH] [--out REPORT.json]

The renderers name their passes with debug-utils labels and their resources
with object names (gpu/debug_names), so both sides use the same names. Lines
only one side can see are listed, not compared: derived lines (depth writes
from the built-in counting-only fragment shaders) and the index reads the
layer derives per draw.

Equal is not enough where nothing was counted: the layer's output must be
complete (every frame asked for), both sides must name the same passes, and
each pass must have at least --min-lines-per-pass equal lines with a non-zero
count (the fewest any built-in renderer's pass counts on the default scene).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def counted_lines(passes, source="counter"):
    """{(pass, resource, access): count} of the lines of one source."""
    out = {}
    for p in passes:
        for r in p["resources"]:
            if r["source"] != source:
                continue
            key = (p["name"], r["name"], r["access"])
            out[key] = out.get(key, 0) + r["count"]
    return out


def site_sums(passes):
    """{(pass, resource, access): count} summed over each pass's sites."""
    out = {}
    for p in passes:
        for site in p.get("sites", []):
            key = (p["name"], site["resource"], site["access"])
            out[key] = out.get(key, 0) + site["count"]
    return out


def site_counts(passes):
    """{(pass, shader, resource, access): sorted counts of its sites}: how a
    line splits over the instructions of each shader, whatever their ids."""
    out = {}
    for p in passes:
        for site in p.get("sites", []):
            out.setdefault((p["name"], site["shader"], site["resource"], site["access"]), []).append(site["count"])
    return {k: sorted(v) for k, v in out.items()}


def check_sites(builtin_passes, layer_passes):
    """With --sites: each side's lines are the sums of its sites, and both
    sides split each line over a shader's sites alike."""
    problems = []
    for side, passes in (("built-in", builtin_passes), ("layer", layer_passes)):
        lines, sums = counted_lines(passes), site_sums(passes)
        for k in sorted(lines.keys() | sums.keys()):
            if lines.get(k, 0) != sums.get(k, 0):
                problems.append("%s %s: line %s, sites sum to %s" % (side, "/".join(k), lines.get(k), sums.get(k)))
        if not sums:
            problems.append("%s: no sites" % side)
    a, b = site_counts(builtin_passes), site_counts(layer_passes)
    for k in sorted(a.keys() | b.keys()):
        if a.get(k, []) != b.get(k, []) and any(a.get(k, [])) | any(b.get(k, [])):
            problems.append("sites of %s: built-in %s, layer %s" % ("/".join(k), a.get(k), b.get(k)))
    return problems


def draw_counts(p, key):
    """A pass's per-draw counts, sorted, zeros left out (a draw that counts
    nothing has no bytes to compare), and its rest's: None where it has none."""
    draws = p.get(key)
    if not isinstance(draws, list):
        return None
    rest = p.get("draws_rest")
    return sorted(d["count"] for d in draws if d["count"] > 0), (rest["draws"], rest["count"]) if rest else None


def check_draws(builtin_passes, layer_passes):
    """With --sites: each pass the built-in renderer counts per draw has the
    same per-draw counts under the layer (its scene draws are the play's draw
    commands: one each, recorded in scene order), and the layer's draws sum
    to its pass's counted lines."""
    problems = []
    layer = {p["name"]: p for p in layer_passes}
    compared = 0
    for p in builtin_passes:
        want = draw_counts(p, "draws")
        if want is None or p["name"] not in layer:
            continue
        got = draw_counts(layer[p["name"]], "draw_list")
        compared += 1
        if got != want:
            problems.append("draws of %s: built-in %s, layer %s" % (p["name"], want, got))
    for p in layer_passes:
        if "draw_list" not in p:
            continue
        lines = sum(r["count"] for r in p["resources"] if r["source"] == "counter")
        draws = sum(d["count"] for d in p["draw_list"]) + p.get("draws_rest", {}).get("count", 0)
        if lines != draws:
            problems.append("layer pass %s: draws sum to %s, counted lines to %s" % (p["name"], draws, lines))
    if compared == 0:
        problems.append("no pass with draws on both sides")
    return problems


def line_kinds(passes):
    """{(pass, resource, access, source): kind}."""
    return {(p["name"], r["name"], r["access"], r["source"]): r["kind"] for p in passes for r in p["resources"]}


def median(values):
    v = sorted(values)
    return v[len(v) // 2] if len(v) % 2 else (v[len(v) // 2 - 1] + v[len(v) // 2]) / 2


def run(command, env=None, timeout=900):
    result = subprocess.run(command, env=env, timeout=timeout, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError("%s exited %d\n%s" % (" ".join(command), result.returncode, result.stderr[-4000:]))
    return result


def compare(args, renderer, tmp, builtin_run):
    output = os.path.join(tmp, renderer + ".layer.json")
    env = dict(os.environ)
    env.update({
        "VK_ADD_LAYER_PATH": args.layer_dir,
        "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters",
        "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters",
        "TALLY_LAYER_OUTPUT": output,
        "TALLY_LAYER_FRAMES": str(args.layer_frames),
        "TALLY_LAYER_STATISTICS_FRAMES": "all",
        "TALLY_LAYER_SKIP_FRAMES": "1",
        "TALLY_LAYER_FRAME_SUBMITS": "1",
        "TALLY_LAYER_COUNTING": args.counting,
        "TALLY_LAYER_SITES": "1" if args.sites else "0",
    })
    camera = builtin_run["samples"][0]["camera"]
    w, h = args.resolution.split("x")
    options = builtin_run.get("options") or {}
    run([args.tallyd, "play", "--renderer", renderer, "--scene", args.scene, "--resolution", args.resolution,
         "--frames", str(args.layer_frames + 1), "--camera", "0", "--quiet"]
        + (["--options", json.dumps(options)] if options else [])
        + (["--device", args.device] if args.device else []), env=env)
    with open(output) as f:
        layer = json.load(f)
    frame = layer["frames"][0]
    a = counted_lines(builtin_run["samples"][0]["passes"])
    b = counted_lines(frame["passes"])
    mismatched = sorted((k, a[k], b[k]) for k in a.keys() & b.keys() if a[k] != b[k])
    only_builtin = sorted(k for k in a.keys() - b.keys() if a[k] != 0)
    only_layer = sorted(k for k in b.keys() - a.keys() if b[k] != 0)
    # Derived lines both sides derive (multisampled targets' writes) must agree
    # too; those only one side derives are listed.
    da = counted_lines(builtin_run["samples"][0]["passes"], "derived")
    db = counted_lines(frame["passes"], "derived")
    mismatched += sorted((k, da[k], db[k]) for k in da.keys() & db.keys() if da[k] != db[k])
    derived_one_side = sorted(list(k) + ["built-in" if k in da else "layer"] for k in da.keys() ^ db.keys())
    ka, kb = line_kinds(builtin_run["samples"][0]["passes"]), line_kinds(frame["passes"])
    kinds_differ = sorted((k, ka[k], kb[k]) for k in ka.keys() & kb.keys() if ka[k] != kb[k])
    # Equal lines with something counted, per pass: a pass where neither side
    # counted anything would otherwise pass as equal.
    counted_equal = {}
    for k in a.keys() & b.keys():
        if a[k] == b[k] and a[k] > 0:
            counted_equal[k[0]] = counted_equal.get(k[0], 0) + 1
    passes_builtin = [p["name"] for p in builtin_run["samples"][0]["passes"]]
    passes_layer = [p["name"] for p in frame["passes"]]
    short = sorted(p for p in set(passes_builtin) | set(passes_layer)
                   if counted_equal.get(p, 0) < args.min_lines_per_pass)
    incomplete = []
    # 64-bit counters where the device has 64-bit buffer atomics, as the built-in renderers use them.
    bits = 64 if args.int64_atomics else 32
    if layer["layer"].get("counter_bits") != bits:
        incomplete.append("the layer counted with %s-bit counters, expected %d (the device's int64Atomics: %s)" %
                          (layer["layer"].get("counter_bits"), bits, args.int64_atomics))
    if layer.get("complete") is not True:
        incomplete.append("the layer's output says complete: %r" % layer.get("complete"))
    if len(layer["frames"]) != args.layer_frames:
        incomplete.append("%d frames in the layer's output, %d asked for" % (len(layer["frames"]), args.layer_frames))
    if args.sites:
        incomplete += check_sites(builtin_run["samples"][0]["passes"], frame["passes"])
        incomplete += check_draws(builtin_run["samples"][0]["passes"], frame["passes"])
    if sorted(passes_builtin) != sorted(passes_layer):
        incomplete.append("passes differ: built-in %s, layer %s" % (passes_builtin, passes_layer))
    times = {p["name"]: p["gpu_ms"] for p in frame["passes"]}
    plain = {p["name"]: p["gpu_ms"] for p in builtin_run["samples"][0]["passes"]}
    return {
        "renderer": builtin_run.get("variant", renderer),
        "lines_equal": len(a.keys() & b.keys()) + len(da.keys() & db.keys()) - len(mismatched),
        "derived_one_side": derived_one_side,
        "mismatched": [{"line": list(k), "builtin": x, "layer": y} for k, x, y in mismatched],
        "kinds_differ": [{"line": list(k), "builtin": x, "layer": y} for k, x, y in kinds_differ],
        "only_builtin": [list(k) for k in only_builtin],
        "only_layer": [list(k) for k in only_layer],
        "passes_builtin": passes_builtin,
        "passes_layer": passes_layer,
        "counted_equal_per_pass": counted_equal,
        "passes_short_of_lines": short,
        "incomplete": incomplete,
        "frame_ms_layer": frame["frame_ms"],
        "frame_ms_layer_median": median([f["frame_ms"] for f in layer["frames"]]),
        "layer_frames": len(layer["frames"]),
        "frame_ms_plain": builtin_run["samples"][0]["frame_ms"],
        "frame_ms_builtin_counted": builtin_run["samples"][0].get("frame_ms_instrumented"),
        "gpu_ms_layer": times,
        "gpu_ms_plain": plain,
        "uninstrumented_shaders": [s for s in layer["shaders"] if not s["instrumented"]],
        "notes": layer["notes"],
    }


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--tallyd", required=True)
    parser.add_argument("--layer-dir", required=True)
    parser.add_argument("--scene", required=True, help="a scene name or a scene object as JSON")
    parser.add_argument("--renderers", default="forward,forward-zprepass,deferred,visbuffer,visbuffer-lean",
                        help="names, comma-separated, or a JSON list of a spec's renderer entries (variants)")
    parser.add_argument("--resolution", default="96x54")
    parser.add_argument("--counting", default="accumulate", help="the layer's mode (the built-in side is exact)")
    parser.add_argument("--builtin-frames", type=int, default=1, help="the capture's uninstrumented frames")
    parser.add_argument("--layer-frames", type=int, default=1, help="frames read back under the layer (after one skipped)")
    parser.add_argument("--device", default="")
    parser.add_argument("--min-lines-per-pass", type=int, default=1,
                        help="equal lines with a non-zero count each pass must have")
    parser.add_argument("--sites", action="store_true",
                        help="count per access site and per draw on both sides: lines are their sites' sums, "
                             "sites and draws agree")
    parser.add_argument("--out", default="")
    args = parser.parse_args()
    args.layer_dir = os.path.abspath(args.layer_dir)
    renderers = json.loads(args.renderers) if args.renderers.startswith("[") else args.renderers.split(",")
    w, h = (int(x) for x in args.resolution.split("x"))
    try:
        scene = json.loads(args.scene)
    except json.JSONDecodeError:
        scene = args.scene
    report = {"scene": scene, "resolution": [w, h], "renderers": []}
    failed = False
    with tempfile.TemporaryDirectory(prefix="tally-layer-compare-") as tmp:
        spec = {"renderers": renderers, "scenes": [scene], "resolutions": [[w, h]], "cameras": "auto",
                "frames": args.builtin_frames, "counted_frames": 1, "counting": "exact", "ceilings": False, "sites": args.sites}
        spec_path, result_path = os.path.join(tmp, "spec.json"), os.path.join(tmp, "builtin.json")
        with open(spec_path, "w") as f:
            json.dump(spec, f)
        run([args.tallyd, "capture", "--spec", spec_path, "--out", result_path, "--quiet"]
            + (["--device", args.device] if args.device else []))
        with open(result_path) as f:
            builtin = json.load(f)
        args.int64_atomics = bool(builtin["device"]["features"]["int64Atomics"])
        for r in builtin["runs"]:
            r["samples"] = r["samples"][:1]  # camera 0 of the auto set
            entry = compare(args, r["renderer"], tmp, r)
            report["renderers"].append(entry)
            ok = (not entry["mismatched"] and not entry["only_builtin"] and not entry["only_layer"]
                  and not entry["kinds_differ"] and not entry["passes_short_of_lines"] and not entry["incomplete"])
            failed = failed or not ok
            print("%-28s %-8s %3d lines equal, %d differ, %d built-in only, %d layer only" %
                  (entry["renderer"], "ok" if ok else "DIFFERS", entry["lines_equal"], len(entry["mismatched"]),
                   len(entry["only_builtin"]), len(entry["only_layer"])))
            for m in entry["mismatched"]:
                print("    %s: built-in %s, layer %s" % ("/".join(m["line"]), m["builtin"], m["layer"]))
            for m in entry["kinds_differ"]:
                print("    %s: kind %s built-in, %s under the layer" % ("/".join(m["line"]), m["builtin"], m["layer"]))
            for k in entry["only_builtin"]:
                print("    built-in only: " + "/".join(k))
            for k in entry["only_layer"]:
                print("    layer only: " + "/".join(k))
            for p in entry["passes_short_of_lines"]:
                print("    pass %s: %d equal counted lines, at least %d required" %
                      (p, entry["counted_equal_per_pass"].get(p, 0), args.min_lines_per_pass))
            for why in entry["incomplete"]:
                print("    " + why)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(report, f, indent=1)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

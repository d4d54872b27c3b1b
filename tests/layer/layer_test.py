#!/usr/bin/env python3
"""The Vulkan layer (layer/, docs/layer.md) on applications Tally did not
write, on lavapipe: vkcube (vulkan-tools) under Xvfb, a GFXReconstruct
capture of it replayed, and a plain compute application (compute_app.cpp)
that uses every descriptor set the device allows in one pipeline layout.

  layer_test.py --build BUILD_DIR --case vkcube|replay|all-sets

Each case derives what the counts must be from the application itself
(fragment invocations, vkcube's 36 vertices, the dispatch size) or from a
second run, never from a stored number.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def statistic(p, key, what):
    """A pass's pipeline statistic, required: the one check independent of
    the layer's counters must not vanish if the layer's query broke (-1 or
    absent). Every device the tests run on (lavapipe, the GPU) has
    pipelineStatisticsQuery."""
    value = p.get(key, -1)
    if value is None or value < 0:
        fail("%s: no %s (the layer's pipeline statistics query gave %r)" % (what, key, value))
    return value


def layer_env(build, output, frames, skip, frame_submits=0):
    env = dict(os.environ)
    env.update({
        "VK_ADD_LAYER_PATH": os.path.join(build, "layer"),
        "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters",
        "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters",
        "TALLY_LAYER_OUTPUT": output,
        "TALLY_LAYER_FRAMES": str(frames),
        "TALLY_LAYER_STATISTICS_FRAMES": "all",
        "TALLY_LAYER_SKIP_FRAMES": str(skip),
        "TALLY_LAYER_FRAME_SUBMITS": str(frame_submits),
    })
    return env


def run(command, env=None, timeout=240):
    result = subprocess.run(command, env=env, timeout=timeout, capture_output=True, text=True)
    if result.returncode != 0:
        fail("%s exited %d\n%s%s" % (" ".join(command), result.returncode, result.stdout[-2000:], result.stderr[-4000:]))
    return result


def glmark2_exited_well(p):
    """glmark2 through zink exits 1 now and then, with or without any layer,
    when X refuses the last software present to its window, already gone
    (BadDrawable, X_PutImage): that ends a run that finished its scene."""
    return p.returncode == 0 or (p.returncode == 1 and "glmark2 Score:" in p.stdout
                                 and "BadDrawable" in p.stderr and "X_PutImage" in p.stderr)


def load(path):
    if not os.path.exists(path):
        fail("the layer wrote no output at " + path)
    with open(path) as f:
        out = json.load(f)
    if not out["complete"]:
        fail("the layer's output is incomplete: %d frames" % len(out["frames"]))
    return out


def lines(pass_):
    """A pass's counted lines by (kind, format, access), handles left out: a
    replay creates its objects anew."""
    out = {}
    for r in pass_["resources"]:
        key = (r["kind"], r["format"], r["access"], r["source"])
        out[key] = out.get(key, 0) + r["count"]
    return out


def check_vkcube_frame(frame):
    if len(frame["passes"]) != 1:
        fail("vkcube frame %d: %d passes, expected its one render pass" % (frame["index"], len(frame["passes"])))
    p = frame["passes"][0]
    fragments = p["fragment_invocations"]
    if fragments <= 0:
        fail("vkcube frame %d: no fragment invocations counted" % frame["index"])
    by_kind = {}
    for r in p["resources"]:
        by_kind.setdefault((r["kind"], r["access"]), []).append(r)
    textures = by_kind.get(("texture", "read"), [])
    # vkcube's fragment shader samples its texture once per invocation and writes one colour.
    if len(textures) != 1 or textures[0]["count"] != fragments:
        fail("vkcube frame %d: texture reads %s != fragment invocations %d" %
             (frame["index"], [t["count"] for t in textures], fragments))
    if textures[0]["bytes"] != fragments * 4:
        fail("vkcube: texture bytes %d != %d reads x 4 (R8G8B8A8)" % (textures[0]["bytes"], fragments))
    writes = [r for r in p["resources"] if r["access"] == "write" and r["kind"] == "attachment"]
    if len(writes) != 1 or writes[0]["count"] != fragments:
        fail("vkcube frame %d: colour writes %s != fragment invocations %d" %
             (frame["index"], [w["count"] for w in writes], fragments))
    # The pipeline statistic counts invocations too, helper lanes of partly
    # covered quads included on lavapipe: it brackets the count from above,
    # within the quads of the cube's edges.
    stat = statistic(p, "fragment_invocations_statistic", "vkcube frame %d" % frame["index"])
    if not (fragments <= stat <= fragments * 1.25):
        fail("vkcube frame %d: statistic %d does not bracket %d counted" % (frame["index"], stat, fragments))
    # 12 triangles, 36 vertices, each reading the MVP, its position and its attribute.
    if p["vertex_invocations"] != 36:
        fail("vkcube: %d vertex invocations, expected 36" % p["vertex_invocations"])
    if statistic(p, "vertex_invocations_statistic", "vkcube") != 36:
        fail("vkcube: vertex statistic %d, expected 36" % p["vertex_invocations_statistic"])
    uniforms = by_kind.get(("buffer", "read"), [])
    if sum(u["count"] for u in uniforms) != 36 * 3:
        fail("vkcube: uniform reads %d, expected 36 x 3" % sum(u["count"] for u in uniforms))
    if p["gpu_ms"] is None or p["gpu_ms"] <= 0:
        fail("vkcube: the pass was not timed")
    return p


def case_vkcube(build, tmp):
    out = os.path.join(tmp, "vkcube.json")
    run(["xvfb-run", "-a", "vkcube", "--c", "8"], env=layer_env(build, out, frames=4, skip=2))
    result = load(out)
    if [f["index"] for f in result["frames"]] != [2, 3, 4, 5]:
        fail("frames %s, expected 2..5 (skip 2, 4 frames)" % [f["index"] for f in result["frames"]])
    for f in result["frames"]:
        check_vkcube_frame(f)
    swap = [r for r in result["resources"] if r["name"] == "swapchain"]
    if not swap or swap[0]["width"] != result["extent"][0]:
        fail("the swapchain is not named as a resource with the extent")
    print("vkcube: %d frames, fragment invocations %s" %
          (len(result["frames"]), [f["passes"][0]["fragment_invocations"] for f in result["frames"]]))


def case_replay(build, tmp):
    """A capture of vkcube, replayed under the layer, counts as the live run
    does, frame by frame; the layer leaves the replayed images unchanged."""
    trace = os.path.join(tmp, "vkcube.gfxr")
    env = dict(os.environ)
    env.update({"VK_INSTANCE_LAYERS": "VK_LAYER_LUNARG_gfxreconstruct", "GFXRECON_CAPTURE_FILE": trace,
                "GFXRECON_CAPTURE_FILE_TIMESTAMP": "false"})
    run(["xvfb-run", "-a", "vkcube", "--c", "8"], env=env)
    if not os.path.exists(trace):
        fail("GFXReconstruct wrote no capture")
    live = os.path.join(tmp, "live.json")
    run(["xvfb-run", "-a", "vkcube", "--c", "8"], env=layer_env(build, live, frames=4, skip=2))
    replayed = os.path.join(tmp, "replay.json")
    shots = {"plain": os.path.join(tmp, "plain"), "layer": os.path.join(tmp, "layer")}
    for d in shots.values():
        os.makedirs(d)
    run(["xvfb-run", "-a", "gfxrecon-replay", "--screenshots", "3-6", "--screenshot-dir", shots["layer"], trace],
        env=layer_env(build, replayed, frames=4, skip=2))
    run(["xvfb-run", "-a", "gfxrecon-replay", "--screenshots", "3-6", "--screenshot-dir", shots["plain"], trace])
    a, b = load(live), load(replayed)
    if [f["index"] for f in a["frames"]] != [f["index"] for f in b["frames"]]:
        fail("live frames %s, replayed %s" % ([f["index"] for f in a["frames"]], [f["index"] for f in b["frames"]]))
    for fa, fb in zip(a["frames"], b["frames"]):
        pa, pb = check_vkcube_frame(fa), check_vkcube_frame(fb)
        if lines(pa) != lines(pb) or pa["fragment_invocations"] != pb["fragment_invocations"]:
            fail("frame %d: live %s, replayed %s" % (fa["index"], lines(pa), lines(pb)))
    names = sorted(os.listdir(shots["plain"]))
    if not names or names != sorted(os.listdir(shots["layer"])):
        fail("screenshots: plain %s, under the layer %s" % (names, sorted(os.listdir(shots["layer"]))))
    for n in names:
        with open(os.path.join(shots["plain"], n), "rb") as x, open(os.path.join(shots["layer"], n), "rb") as y:
            if x.read() != y.read():
                fail("replayed image %s differs under the layer" % n)
    print("replay: %d frames equal to the live run; %d screenshots identical with and without the layer" %
          (len(a["frames"]), len(names)))


def case_all_sets(build, tmp):
    """compute_app's "bump" pipeline layout uses every set: the layer refuses
    it, says so and runs it unchanged (the app checks its own results); its
    "fill" pipeline is counted. No present: a frame is one submission."""
    app = os.path.join(build, "tests", "layer", "tally_layer_compute_app")
    out = os.path.join(tmp, "compute.json")
    run([app, "--frames", "4"], env=layer_env(build, out, frames=2, skip=1, frame_submits=1))
    result = load(out)
    if not any("uses" in n and "descriptor sets" in n and "unchanged" in n for n in result["notes"]):
        fail("no note that a layout uses every descriptor set: %s" % result["notes"])
    if [f["index"] for f in result["frames"]] != [1, 2]:
        fail("frames %s, expected 1 and 2" % [f["index"] for f in result["frames"]])
    count = 64 * 50
    for f in result["frames"]:
        passes = {p["name"]: p for p in f["passes"]}
        if set(passes) != {"fill", "bump"}:
            fail("passes %s, expected the labels fill and bump" % sorted(passes))
        fill, bump = passes["fill"], passes["bump"]
        if fill["compute_invocations"] != count:
            fail("fill: %d invocations counted, expected %d" % (fill["compute_invocations"], count))
        if statistic(fill, "compute_invocations_statistic", "fill") != count:
            fail("fill: statistic %d, expected %d" % (fill["compute_invocations_statistic"], count))
        out_lines = [r for r in fill["resources"] if r["name"] == "out" and r["access"] == "write"]
        if len(out_lines) != 1 or out_lines[0]["count"] != count or out_lines[0]["bytes"] != count * 4:
            fail("fill: writes of 'out' %s, expected %d of 4 bytes" % (fill["resources"], count))
        if bump["resources"] or bump["compute_invocations"] != 0 or bump["dispatches"] != 1:
            fail("bump ran counted, or was not seen: %s" % bump)
        if statistic(bump, "compute_invocations_statistic", "bump") != count:
            fail("bump: statistic %d, expected %d (it ran)" % (bump["compute_invocations_statistic"], count))
    print("all-sets: refused layout noted, its pass ran uncounted; fill counted %d writes per frame" % count)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    parser.add_argument("--case", required=True, choices=["vkcube", "replay", "all-sets"])
    args = parser.parse_args()
    for tool in ("xvfb-run", "vkcube", "gfxrecon-replay"):
        if shutil.which(tool) is None:
            fail(tool + " is not installed (scripts/setup.sh installs xvfb, vulkan-tools and gfxreconstruct)")
    build = os.path.abspath(args.build)
    with tempfile.TemporaryDirectory(prefix="tally-layer-") as tmp:
        {"vkcube": case_vkcube, "replay": case_replay, "all-sets": case_all_sets}[args.case](build, tmp)


if __name__ == "__main__":
    main()

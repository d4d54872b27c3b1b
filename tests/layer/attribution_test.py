#!/usr/bin/env python3
"""Where the Vulkan layer attributes counts (docs/layer.md, "How counts are
attributed"), on lavapipe:

  attribution_test.py --build BUILD_DIR --case app|glmark2

app: attribution_app.cpp under the layer (and the Khronos validation layer
below it): every line of every pass equals what its geometry gives. Each
draw is a triangle covering its viewport of W x H = 64 x 48 pixels, so one
fragment per pixel; three vertices, each reading two R32G32_SFLOAT attributes
(8 bytes each: the format's element, where the shader reads a float). Outputs
without an attachment, with a write mask of 0, with colour writes disabled,
or under rasterizer discard have no line; secondaries' outputs are named by
the attachments they inherit; passes sharing a label are numbered; a
multiview scope is timed and has statistics.

glmark2: OpenGL through zink (Mesa's GL on Vulkan) under the layer at
320x240: no line for an output without an attachment, none for the colour of
the shadow scene's depth-only pass, textures read as "texture" (zink creates
every image with attachment usage), and colour writes equal to the fragment
invocations (texture scene) or to the target's W x H (terrain's full-screen
passes).
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from strict import skip_or_fail  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from layer_test import fail, glmark2_exited_well, load, run  # noqa: E402

W, H = 64, 48
N = W * H


def layer_env(build, output, frames, skip, frame_submits=0, below=""):
    env = dict(os.environ)
    layers = "VK_LAYER_TALLY_counters" + (":" + below if below else "")
    env.update({
        "VK_ADD_LAYER_PATH": os.path.join(build, "layer"),
        "VK_INSTANCE_LAYERS": layers,
        "VK_LOADER_LAYERS_ENABLE": layers.replace(":", ","),
        "TALLY_LAYER_OUTPUT": output,
        "TALLY_LAYER_FRAMES": str(frames),
        "TALLY_LAYER_STATISTICS_FRAMES": "all",
        "TALLY_LAYER_SKIP_FRAMES": str(skip),
        "TALLY_LAYER_FRAME_SUBMITS": str(frame_submits),
    })
    return env


def lines_of(p):
    out = {}
    for r in p["resources"]:
        key = (r["name"], r["access"], r["kind"])
        if key in out:
            fail("pass %s: two lines %s" % (p["name"], key))
        out[key] = (r["count"], r["bytes"])
    return out


def vertex_reads(draws, vertices=3):
    """Two R32G32_SFLOAT attributes per vertex, 8 bytes each."""
    reads = draws * vertices * 2
    return {("triangle", "read", "buffer"): (reads, reads * 8)}


def expected_app_passes():
    """Each pass's lines, from the geometry: a W x H viewport is N fragments,
    each writing every attachment it may (4-byte texels), each reading its
    texels once."""
    def write(name, count=N, texel=4):
        return {(name, "write", "attachment"): (count, count * texel)}

    def read(name, kind, texel=4):
        return {(name, "read", kind): (N, N * texel)}

    return [
        # Locations 0..3: "colour a", unused, "colour b" with mask 0, "colour c" (R32_SFLOAT).
        ("split", {**write("colour a"), **write("colour c"), **vertex_reads(1)}, N),
        ("depth only", vertex_reads(1), N),
        # Two secondaries, one half of the viewport each.
        ("secondary", {**write("colour e"), **vertex_reads(2)}, N),
        ("discard", vertex_reads(1), 0),
        ("multiview", None, 2 * N),  # below: two views
        # Location 1's view is null; Location 2 has no attachment.
        ("blit", {**read("colour a", "texture"), **write("colour d"), **vertex_reads(1)}, N),
        # Location 1 disabled (vkCmdSetColorWriteEnableEXT), Location 2 masked (vkCmdSetColorWriteMaskEXT).
        ("blit #2", {**read("colour c", "texture"), **write("colour d"), **vertex_reads(1)}, N),
        ("secondary rendering", {**write("colour f"), **vertex_reads(1)}, N),
        ("compute", {**read("colour a", "texture"), **read("storage in", "storage image"),
                     ("storage out", "write", "storage image"): (N, 4 * N)}, 0),
    ]


def check_app_frame(frame):
    expected = expected_app_passes()
    names = [p["name"] for p in frame["passes"]]
    if names != [e[0] for e in expected]:
        fail("frame %d: passes %s, expected %s" % (frame["index"], names, [e[0] for e in expected]))
    for p, (name, want, fragments) in zip(frame["passes"], expected):
        got = lines_of(p)
        if name == "multiview":
            # Vertex invocations per view are the implementation's choice:
            # the pipeline statistic gives them.
            views_vertices = p["vertex_invocations_statistic"]
            if views_vertices < 6:
                fail("multiview: vertex statistic %r, at least 3 vertices x 2 views" % views_vertices)
            want = {("layers", "write", "attachment"): (2 * N, 8 * N),
                    ("triangle", "read", "buffer"): (2 * views_vertices, 16 * views_vertices)}
        if got != want:
            fail("frame %d, pass %s: lines\n  %s\nexpected\n  %s" % (frame["index"], name, sorted(got.items()),
                                                                     sorted(want.items())))
        if p["fragment_invocations"] != fragments:
            fail("pass %s: %d fragment invocations, expected %d" % (name, p["fragment_invocations"], fragments))
        if p["gpu_ms"] is None or p["gpu_ms"] < 0:
            fail("pass %s is not timed (gpu_ms %r)" % (name, p["gpu_ms"]))
        # Statistics: none where the pass's work is in secondaries (no query
        # may be active around them); elsewhere they bracket the count from
        # above (helper lanes), the multiview scope's summed over its views.
        statistic = p["fragment_invocations_statistic"]
        if name.startswith("secondary"):
            if statistic != -1:
                fail("pass %s: a statistic %r around secondaries" % (name, statistic))
        elif not fragments <= statistic <= fragments * 1.25:
            fail("pass %s: fragment statistic %r does not bracket %d" % (name, statistic, fragments))
    compute = frame["passes"][-1]
    if compute["compute_invocations"] != N or compute["compute_invocations_statistic"] != N:
        fail("compute: %d invocations, statistic %d, expected %d" %
             (compute["compute_invocations"], compute["compute_invocations_statistic"], N))


def case_app(build, tmp):
    app = os.path.join(build, "tests", "layer", "tally_layer_attribution_app")
    out = os.path.join(tmp, "app.json")
    validation = any(os.path.exists(os.path.join(d, "VkLayer_khronos_validation.json"))
                     for d in ("/usr/share/vulkan/explicit_layer.d", "/etc/vulkan/explicit_layer.d"))
    if not validation:
        skip_or_fail("the Khronos validation layer is not installed (vulkan-validationlayers)")
    result = run([app, "--frames", "4"],
                 env=layer_env(build, out, frames=2, skip=1, frame_submits=1, below="VK_LAYER_KHRONOS_validation"))
    errors = [line for line in result.stdout.splitlines() + result.stderr.splitlines() if "Validation Error" in line]
    if errors:
        fail("the validation layer below the layer reports:\n" + "\n".join(errors[:5]))
    output = load(out)
    if [f["index"] for f in output["frames"]] != [1, 2]:
        fail("frames %s, expected 1 and 2" % [f["index"] for f in output["frames"]])
    for f in output["frames"]:
        check_app_frame(f)
    print("app: %d frames, %d passes each, every line as the geometry gives" %
          (len(output["frames"]), len(output["frames"][0]["passes"])))


def start_xvfb():
    """An X server on a free display, started without the layer's variables
    (it loads Mesa too)."""
    read, write = os.pipe()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VK_", "TALLY_", "GALLIUM", "MESA", "LIBGL"))}
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                            pass_fds=(write,), env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as f:
        display = f.readline().strip()
    if not display:
        xvfb.kill()
        fail("Xvfb gave no display")
    return xvfb, ":" + display


def glmark2(build, tmp, display, scene, frames, skip, duration):
    out = os.path.join(tmp, scene + ".json")
    env = layer_env(build, out, frames=frames, skip=skip)
    env.update({"LIBGL_ALWAYS_SOFTWARE": "1", "GALLIUM_DRIVER": "zink", "MESA_LOADER_DRIVER_OVERRIDE": "zink",
                "XDG_RUNTIME_DIR": tmp, "DISPLAY": display})
    command = ["glmark2", "-b", "%s:duration=%d" % (scene, duration), "-s", "320x240"]
    result = subprocess.run(command, env=env, timeout=240, capture_output=True, text=True)
    if not glmark2_exited_well(result):
        fail("%s exited %d\n%s%s" % (" ".join(command), result.returncode, result.stdout[-2000:], result.stderr[-4000:]))
    output = load(out)
    if output["application"]["engine"] != "mesa zink":
        fail("%s: the engine is %r, not zink" % (scene, output["application"]["engine"]))
    for f in output["frames"]:
        for p in f["passes"]:
            for r in p["resources"]:
                if re.fullmatch(r"output \d+", r["name"]):
                    fail("%s, pass %s: a line for an output with no attachment: %s" % (scene, p["name"], r))
    return output


def check_texture(output):
    for f in output["frames"]:
        if len(f["passes"]) != 1:
            fail("texture: %d passes, expected one" % len(f["passes"]))
        p = f["passes"][0]
        fragments = p["fragment_invocations"]
        writes = [r for r in p["resources"] if r["access"] == "write"]
        textures = [r for r in p["resources"] if r["access"] == "read" and r["kind"] == "texture"]
        if len(writes) != 1 or writes[0]["name"] != "swapchain" or writes[0]["count"] != fragments:
            fail("texture: writes %s, expected the swapchain's, one per fragment invocation (%d)" % (writes, fragments))
        if writes[0]["kind"] != "attachment" or writes[0]["bytes"] != 4 * fragments:
            fail("texture: the swapchain line %s, expected an attachment of 4-byte texels" % writes[0])
        # The scene samples its one texture once per fragment.
        if len(textures) != 1 or textures[0]["count"] != fragments:
            fail("texture: texture reads %s, expected one line of %d" % (p["resources"], fragments))
        statistic = p["fragment_invocations_statistic"]
        if not 0 < fragments <= statistic <= fragments * 1.25:
            fail("texture: statistic %r does not bracket %d counted" % (statistic, fragments))


def check_shadow(output):
    """The shadow map is drawn in a depth-only pass and sampled by the next."""
    for f in output["frames"]:
        passes = f["passes"]
        found = False
        for i, p in enumerate(passes):
            maps = [r for r in p["resources"] if r["access"] == "read" and re.match(r"(D\d\d|X8_?D24)", r["format"])]
            if not maps:
                continue
            found = True
            if any(r["kind"] != "texture" for r in maps):
                fail("shadow: the sampled shadow map is not a texture: %s" % maps)
            depth_pass = passes[i - 1] if i > 0 else None
            if depth_pass is None or depth_pass["fragment_invocations"] <= 0:
                fail("shadow: no depth pass with fragments before %s" % p["name"])
            colour = [r for r in depth_pass["resources"] if r["access"] == "write"]
            if colour:
                fail("shadow: the depth-only pass %s has colour lines %s" % (depth_pass["name"], colour))
        if not found:
            fail("shadow: no pass samples a depth image: %s" % [p["name"] for p in passes])


def check_terrain(output):
    """Full-screen passes (a quad: 6 vertices by the pipeline statistic)
    write each pixel of their target once."""
    sizes = {r["name"]: r["width"] * r["height"] for r in output["resources"]}
    checked = 0
    for f in output["frames"]:
        for p in f["passes"]:
            if p["vertex_invocations_statistic"] != 6 or p["fragment_invocations"] == 0:
                continue  # not a quad, or a fragment stage the layer could not instrument
            writes = [r for r in p["resources"] if r["access"] == "write"]
            if len(writes) != 1 or writes[0]["count"] != sizes.get(writes[0]["name"]):
                fail("terrain, pass %s: writes %s, expected one target's W x H %s" %
                     (p["name"], writes, {w["name"]: sizes.get(w["name"]) for w in writes}))
            if p["fragment_invocations"] != writes[0]["count"]:
                fail("terrain, pass %s: %d fragments for %d pixels" % (p["name"], p["fragment_invocations"],
                                                                     writes[0]["count"]))
            checked += 1
    if checked == 0:
        fail("terrain: no full-screen pass was counted")


def case_glmark2(build, tmp):
    for tool in ("glmark2", "Xvfb"):
        if shutil.which(tool) is None:
            skip_or_fail(tool + " is not installed (glmark2, xvfb)")
    xvfb, display = start_xvfb()
    try:
        check_texture(glmark2(build, tmp, display, "texture", frames=3, skip=10, duration=3))
        check_shadow(glmark2(build, tmp, display, "shadow", frames=2, skip=5, duration=3))
        check_terrain(glmark2(build, tmp, display, "terrain", frames=2, skip=3, duration=5))
    finally:
        xvfb.terminate()
        xvfb.wait()
    print("glmark2: texture, shadow and terrain attributed as their geometry gives")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    parser.add_argument("--case", required=True, choices=["app", "glmark2"])
    args = parser.parse_args()
    build = os.path.abspath(args.build)
    with tempfile.TemporaryDirectory(prefix="tally-attribution-") as tmp:
        {"app": case_app, "glmark2": case_glmark2}[args.case](build, tmp)


if __name__ == "__main__":
    main()

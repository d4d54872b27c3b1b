"""What the layer must count for glmark2's scenes and ffmpeg's Vulkan
filters (clients_test.py), per frame, derived from the applications' own
source and the frame size, never from a run of the layer.

Each function takes the run `tallyd capture` stores (result["runs"][0]: its
samples are the frames) and records every relation that fails.

lavapipe's fragment-invocation statistic counts 4x4 blocks: llvmpipe shades
a triangle in blocks of 16 pixels and adds 16 for each block holding at
least one of its fragments. So the statistic brackets a pass's counted
invocations: count <= statistic <= 16 x count for any geometry, and within
1.25 x count where triangles are large (a cube, a full-screen quad: the
blocks their edges cut are few beside those they fill).
"""

BLOCK = 16  # llvmpipe's fragment block, 4x4
LARGE_TRIANGLES = 1.25


def works(p, count, statistic):
    """Whether a pass draws (or dispatches): the layer's count of them (a
    result's "draw_count": with per-draw counts "draws" is their list), or
    where the store keeps none, the pass's invocations statistic."""
    if count == "draws" and "draw_count" in p:
        count = "draw_count"
    return p[count] > 0 if count in p else (p.get(statistic) or 0) > 0


def drawn(sample):
    """The frame's passes that draw (zink opens empty rendering scopes for clears)."""
    return [p for p in sample["passes"] if works(p, "draws", "fragment_invocations_statistic")]


def writes(p):
    return [r for r in p["resources"] if r["access"] == "write"]


def image_reads(p):
    return [r for r in p["resources"] if r["access"] == "read" and r["kind"] != "buffer"]


def size_of(run, name):
    for r in run["resources"]["list"]:
        if r["name"] == name:
            return (r.get("width", 0), r.get("height", 0))
    return None


def bracket(failures, where, p, upper):
    """count <= statistic <= upper x count (the statistic is required: the
    one check independent of the layer's counters must not vanish)."""
    count, stat = p.get("fragment_invocations", 0), p.get("fragment_invocations_statistic")
    if not failures.check(stat is not None and stat >= 0, "%s: no fragment-invocation statistic" % where):
        return
    failures.check(0 < count <= stat <= upper * count,
                   "%s: statistic %d does not bracket the %d fragment invocations counted (<= %g x)" %
                   (where, stat, count, upper))


def window_writes(failures, where, p):
    """The pass that draws to the window writes one colour per fragment to
    the swapchain, and to nothing else: glmark2 has one colour attachment."""
    lines = writes(p)
    failures.check([r["name"] for r in lines] == ["swapchain"],
                   "%s: colour writes to %s, expected to the swapchain only" %
                   (where, sorted("%s (%d)" % (r["name"], r["count"]) for r in lines)))
    swap = [r for r in lines if r["name"] == "swapchain"]
    failures.check(len(swap) == 1 and swap[0]["count"] == p["fragment_invocations"],
                   "%s: swapchain writes %s != %d fragment invocations" %
                   (where, [r["count"] for r in swap], p["fragment_invocations"]))


def glmark2_common(run, failures, width, height, skip, frames):
    notes = run["notes"]
    failures.check(run["renderer"] == "app:glmark2", "stored as %s, expected app:glmark2" % run["renderer"])
    engine = notes.get("application", {}).get("engine")
    failures.check(engine == "mesa zink", "the application's engine is %r, not zink's 'mesa zink'" % engine)
    failures.check((run["width"], run["height"]) == (width, height),
                   "frame size %dx%d, expected the window's %dx%d" % (run["width"], run["height"], width, height))
    failures.check(size_of(run, "swapchain") == (width, height),
                   "the swapchain is %s, expected %dx%d" % (size_of(run, "swapchain"), width, height))
    indices = [s["camera"]["frame"] for s in run["samples"]]
    failures.check(indices == list(range(skip, skip + frames)),
                   "frames %s, expected %d..%d" % (indices, skip, skip + frames - 1))
    # Every stage of every pipeline instrumented: nothing ran uncounted.
    reasons = sorted({"%s: %s" % (s["stage"], s["reason"][:160]) for s in notes.get("uninstrumented_shaders", [])})
    failures.check(not reasons, "%d shader stages not instrumented: %s" %
                   (len(notes.get("uninstrumented_shaders", [])), reasons))


def glmark2_texture(run, failures, width, height):
    """A textured cube (light-basic-tex.frag): one texture2D per fragment,
    one colour per fragment to the window."""
    for s in run["samples"]:
        where = "frame %d" % s["camera"]["frame"]
        passes = drawn(s)
        if not failures.check(len(passes) == 1, "%s: %d passes draw, expected the cube's one" % (where, len(passes))):
            continue
        p = passes[0]
        reads = image_reads(p)
        failures.check(len(reads) == 1 and reads[0]["count"] == p["fragment_invocations"],
                       "%s: texture reads %s != %d fragment invocations (one sample each)" %
                       (where, [(r["name"], r["count"]) for r in reads], p["fragment_invocations"]))
        if len(reads) == 1:
            failures.check(reads[0]["bytes"] == 4 * reads[0]["count"] and reads[0]["format"] == "R8G8B8A8_UNORM",
                           "%s: texture bytes %d for %d reads of %s" %
                           (where, reads[0]["bytes"], reads[0]["count"], reads[0]["format"]))
        window_writes(failures, where, p)
        bracket(failures, where, p, LARGE_TRIANGLES)


def glmark2_model(run, failures, width, height):
    """build and shading: the horse (7,172 small triangles) in one pass."""
    for s in run["samples"]:
        where = "frame %d" % s["camera"]["frame"]
        passes = drawn(s)
        if not failures.check(len(passes) == 1, "%s: %d passes draw, expected one" % (where, len(passes))):
            continue
        window_writes(failures, where, passes[0])
        bracket(failures, where, passes[0], BLOCK)


def glmark2_shadow(run, failures, width, height):
    """A depth-only pass into a 2W x 2H depth texture (colour masked, no
    colour attachment), then the window: the ground quad samples the depth
    once per fragment (shadow.frag), the horse nothing."""
    for s in run["samples"]:
        where = "frame %d" % s["camera"]["frame"]
        passes = drawn(s)
        if not failures.check(len(passes) == 2, "%s: %d passes draw, expected depth and window" %
                              (where, len(passes))):
            continue
        depth, window = passes
        failures.check(not writes(depth), "%s: the depth-only pass writes colour to %s" %
                       (where, sorted("%s (%d)" % (r["name"], r["count"]) for r in writes(depth))))
        bracket(failures, where + " depth pass", depth, BLOCK)
        window_writes(failures, where, window)
        bracket(failures, where + " window pass", window, BLOCK)
        reads = image_reads(window)
        failures.check(len(reads) == 1 and size_of(run, reads[0]["name"]) == (2 * width, 2 * height)
                       and 0 < reads[0]["count"] < window["fragment_invocations"],
                       "%s: shadow-map reads %s, expected one line of the %dx%d depth texture, fewer than the "
                       "pass's %d fragments" % (where, [(r["name"], r["count"]) for r in reads], 2 * width,
                                                2 * height, window["fragment_invocations"]))


def terrain_passes(width, height):
    """glmark2's terrain scene (scene-terrain.cpp, bloom and tilt-shift on,
    the defaults): its passes in order, each (name, target size, texture
    reads per fragment and the size of what it reads); None for the terrain
    mesh, the one pass not a full-screen quad."""
    screen, bloom = (width, height), (256, 256)
    return [
        ("height map (simplex noise)", bloom, 0, None),
        ("normal map (3 height samples)", bloom, 3, bloom),
        ("terrain", None, None, None),
        ("bloom horizontal (radius 2)", bloom, 5, screen),
        ("bloom vertical (radius 2)", bloom, 5, bloom),
        ("bloom overlay onto the terrain", screen, 1, bloom),
        ("tilt-shift horizontal (radius 4)", screen, 9, screen),
        ("tilt-shift vertical to the window (radius 4)", screen, 9, screen),
    ]


def glmark2_terrain(run, failures, width, height):
    """Full-screen passes write each pixel of their target once and read
    (2 x radius + 1) taps per pixel for a blur (blur-renderer.cpp)."""
    expected = terrain_passes(width, height)
    for s in run["samples"]:
        passes = drawn(s)
        if not failures.check(len(passes) == len(expected), "frame %d: %d passes draw, expected %d" %
                              (s["camera"]["frame"], len(passes), len(expected))):
            continue
        for p, (name, target, taps, source) in zip(passes, expected):
            where = "frame %d, %s (%s)" % (s["camera"]["frame"], p["name"], name)
            if target is None:
                bracket(failures, where, p, BLOCK)
                continue
            lines = writes(p)
            last = p is passes[-1]
            failures.check(len(lines) == 1 and lines[0]["count"] == target[0] * target[1]
                           and (lines[0]["name"] == "swapchain") == last
                           and size_of(run, lines[0]["name"]) == target,
                           "%s: writes %s, expected %d x %d = %d to one %s" %
                           (where, [(r["name"], r["count"]) for r in lines], target[0], target[1],
                            target[0] * target[1], "swapchain" if last else "attachment of that size"))
            reads = image_reads(p)
            want = [taps * target[0] * target[1]] if taps else []
            failures.check([r["count"] for r in reads] == want
                           and all(size_of(run, r["name"]) == source for r in reads),
                           "%s: texture reads %s, expected %s of a %s image" %
                           (where, [(r["name"], r["count"]) for r in reads], want, source))
            bracket(failures, where, p, LARGE_TRIANGLES)


GLMARK2 = {"texture": glmark2_texture, "build": glmark2_model, "shading": glmark2_model,
           "terrain": glmark2_terrain, "shadow": glmark2_shadow}


def ffmpeg_common(run, failures, skip, frames):
    failures.check(run["notes"].get("application", {}).get("name") == "ffmpeg",
                   "the application is %s" % run["notes"].get("application"))
    indices = [s["camera"]["frame"] for s in run["samples"]]
    failures.check(indices == list(range(skip, skip + frames)),
                   "frames %s, expected %d..%d" % (indices, skip, skip + frames - 1))
    reasons = [s["reason"] for s in run["notes"].get("uninstrumented_shaders", [])]
    failures.check(not reasons, "shaders not instrumented: %s" % reasons)


def plane_lines(run, p):
    """{(access, (width, height)): [counts]} of a pass's image lines, sorted."""
    out = {}
    for r in p["resources"]:
        out.setdefault((r["access"], size_of(run, r["name"])), []).append(r["count"])
    return {k: sorted(v) for k, v in out.items()}


def compute_pass(failures, where, sample):
    passes = sample["passes"]
    if not failures.check(len(passes) == 1 and works(passes[0], "dispatches", "compute_invocations_statistic"),
                          "%s: passes %s, expected one compute pass" % (where, [p["name"] for p in passes])):
        return None
    p = passes[0]
    failures.check(all(r["bytes"] == r["count"] for r in p["resources"]),
                   "%s: bytes differ from counts on R8_UNORM planes: %s" %
                   (where, [(r["name"], r["count"], r["bytes"]) for r in p["resources"]]))
    return p


def ffmpeg_avgblur(run, failures, width, height):
    """avgblur_vulkan in Debian's ffmpeg 5.1 (vf_avgblur_vulkan.c): a
    horizontal then a vertical pass, each one dispatch of 32-wide (then
    32-tall) work groups over the frame. An invocation inside a plane's size
    stores once to it; for a filtered plane it first samples 3 texels (its
    own, one FILTER_RADIUS = sizeX - 1 before it, one a work group after it,
    into a shared cache), whatever the radius; an unfiltered plane is
    sampled once. planes=1: luma filtered, both chroma planes copied. Pass
    one reads the input frame and writes a temporary frame; pass two reads
    that and writes the output frame."""
    luma, chroma = (width, height), (width // 2, height // 2)
    lw, cw = width * height, chroma[0] * chroma[1]
    expected = {
        ("read", luma): [3 * lw, 3 * lw],        # input luma, then temporary luma
        ("write", luma): [lw, lw],               # temporary, then output
        ("read", chroma): [cw] * 4,              # input U, V, then temporary U, V
        ("write", chroma): [cw] * 4,             # temporary U, V, then output U, V
    }
    groups = -(-width // 32) * 32 * height + width * (-(-height // 32) * 32)
    for s in run["samples"]:
        where = "frame %d" % s["camera"]["frame"]
        p = compute_pass(failures, where, s)
        if p is None:
            continue
        got = plane_lines(run, p)
        failures.check(got == expected, "%s: plane lines %s, expected %s" % (where, got, expected))
        failures.check(p["compute_invocations"] == groups and p.get("compute_invocations_statistic") == groups,
                       "%s: compute invocations %s (statistic %s), expected the two dispatches' %d" %
                       (where, p["compute_invocations"], p.get("compute_invocations_statistic"), groups))


def ffmpeg_scale(run, failures, width, height):
    """scale_vulkan in ffmpeg 5.1 (vf_scale_vulkan.c), yuv420p to yuv420p
    at half size: one dispatch; each invocation inside an output plane
    samples the input plane once (scale_bilinear) and stores once."""
    out_w, out_h = width // 2, height // 2
    expected = {
        ("read", (width, height)): [out_w * out_h],
        ("read", (width // 2, height // 2)): [(out_w // 2) * (out_h // 2)] * 2,
        ("write", (out_w, out_h)): [out_w * out_h],
        ("write", (out_w // 2, out_h // 2)): [(out_w // 2) * (out_h // 2)] * 2,
    }
    for s in run["samples"]:
        where = "frame %d" % s["camera"]["frame"]
        p = compute_pass(failures, where, s)
        if p is None:
            continue
        got = plane_lines(run, p)
        failures.check(got == expected, "%s: plane lines %s, expected %s" % (where, got, expected))
        stat = p.get("compute_invocations_statistic")
        failures.check(p["compute_invocations"] == stat and stat >= out_w * out_h,
                       "%s: compute invocations %s, statistic %s, expected equal and >= %d" %
                       (where, p["compute_invocations"], stat, out_w * out_h))


FFMPEG = {"avgblur": ffmpeg_avgblur, "scale": ffmpeg_scale}

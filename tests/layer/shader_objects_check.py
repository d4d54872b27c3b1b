#!/usr/bin/env python3
"""Checks the layer's output for shader_object_app.cpp (shader objects,
VK_EXT_shader_object) against counts derived from the application by hand:

  shader_objects_check.py --output LAYER_OUTPUT.json --case separate|linked|binary

Each frame of the window has the app's two passes:
  "shaded": two triangles covering a 64 x 64 target once: 4,096 fragment
            invocations, each reading the uniform block "tint" (a vec4, 16 B)
            once and writing one R8G8B8A8 texel (4 B) of "target"; 6 vertex
            invocations, each reading one vec2 (8 B) of "positions".
  "fill":   3,200 compute invocations, each writing one uint (4 B) of "out";
            in the binary case its shader came from vkGetShaderBinaryDataEXT,
            which the layer cannot instrument: no line, no invocation, and the
            shader reported with the reason.
The pipeline statistics (queried by the layer around each pass, independent
of its counters) must equal the compute count and bracket the fragment count
from above (helper lanes).
"""
import argparse
import json
import sys

SIZE = 64
FRAGMENTS = SIZE * SIZE
VERTICES = 6
INVOCATIONS = 64 * 50


def fail(message):
    print("FAIL: " + message)
    sys.exit(1)


def lines_of(p):
    out = {}
    for r in p["resources"]:
        key = (r["name"], r["access"])
        if key in out:
            fail("pass %s: two lines %s" % (p["name"], key))
        out[key] = (r["count"], r["bytes"], r["kind"])
    return out


def expect_lines(p, want):
    got = lines_of(p)
    if got != want:
        fail("pass %s: lines %s, expected %s" % (p["name"], sorted(got.items()), sorted(want.items())))


def statistic(p, key):
    value = p.get(key, -1)
    if value is None or value < 0:
        fail("pass %s: no %s (the layer's pipeline statistics query gave %r)" % (p["name"], key, value))
    return value


def check_shaded(p):
    if p["draws"] != 1:
        fail("shaded: %d draws, expected 1" % p["draws"])
    if p["fragment_invocations"] != FRAGMENTS:
        fail("shaded: %d fragment invocations counted, expected %d" % (p["fragment_invocations"], FRAGMENTS))
    # The statistic may count the helper lanes of the quads the triangles'
    # shared edge cuts (as on lavapipe): it brackets the count from above.
    stat = statistic(p, "fragment_invocations_statistic")
    if not FRAGMENTS <= stat <= FRAGMENTS * 1.25:
        fail("shaded: fragment statistic %d does not bracket %d counted" % (stat, FRAGMENTS))
    if p["vertex_invocations"] != VERTICES:
        fail("shaded: %d vertex invocations counted, expected %d" % (p["vertex_invocations"], VERTICES))
    expect_lines(p, {
        ("target", "write"): (FRAGMENTS, FRAGMENTS * 4, "attachment"),
        ("tint", "read"): (FRAGMENTS, FRAGMENTS * 16, "buffer"),
        ("positions", "read"): (VERTICES, VERTICES * 8, "buffer"),
    })


def check_fill(p, binary):
    if p["dispatches"] != 1:
        fail("fill: %d dispatches, expected 1" % p["dispatches"])
    if statistic(p, "compute_invocations_statistic") != INVOCATIONS:
        fail("fill: compute statistic %d, expected %d" % (p["compute_invocations_statistic"], INVOCATIONS))
    if binary:
        if p["compute_invocations"] != 0 or p["resources"]:
            fail("fill: a binary shader object counted %d invocations and lines %s; it cannot be instrumented" %
                 (p["compute_invocations"], lines_of(p)))
        return
    if p["compute_invocations"] != INVOCATIONS:
        fail("fill: %d compute invocations counted, expected %d" % (p["compute_invocations"], INVOCATIONS))
    expect_lines(p, {("out", "write"): (INVOCATIONS, INVOCATIONS * 4, "buffer")})


def check_shaders(result, binary):
    shaders = [s for s in result["shaders"] if s["name"].startswith("shader object")]
    stages = sorted(s["stage"] for s in shaders if s["instrumented"])
    # The binary case also creates the SPIR-V compute shader whose binary it
    # takes: that one is instrumented like any other (it is never dispatched).
    want = ["compute", "fragment", "vertex"]
    if stages != want:
        fail("instrumented shader objects: %s, expected %s (shaders: %s)" % (stages, want, shaders))
    if binary:
        refused = [s for s in shaders if not s["instrumented"] and "VK_SHADER_CODE_TYPE_BINARY_EXT" in s["reason"]]
        if len(refused) != 1:
            fail("the binary shader object is not reported with its reason: %s" % shaders)
        if not any("VK_SHADER_CODE_TYPE_BINARY_EXT" in n for n in result["notes"]):
            fail("no note says a binary shader object runs uncounted: %s" % result["notes"])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--output", required=True)
    parser.add_argument("--case", required=True, choices=["separate", "linked", "binary"])
    parser.add_argument("--frames", type=int, default=2)
    args = parser.parse_args()
    with open(args.output) as f:
        result = json.load(f)
    if not result["layer"]["counting_enabled"]:
        fail("the layer did not count: %s" % result["layer"]["not_counting"])
    if len(result["frames"]) != args.frames:
        fail("%d frames written, expected %d" % (len(result["frames"]), args.frames))
    binary = args.case == "binary"
    check_shaders(result, binary)
    # Created: vertex, fragment, compute, and in the binary case the shader
    # made from the compute shader's binary, which gets no twin.
    created = (result["layer"]["shader_objects"], result["layer"]["shader_objects_counted"])
    if created != ((4, 3) if binary else (3, 3)):
        fail("shader objects created, counted: %s, expected %s" % (created, (4, 3) if binary else (3, 3)))
    for frame in result["frames"]:
        names = [p["name"] for p in frame["passes"]]
        if names != ["shaded", "fill"]:
            fail("frame %d: passes %s, expected ['shaded', 'fill']" % (frame["index"], names))
        check_shaded(frame["passes"][0])
        check_fill(frame["passes"][1], binary)
    print("shader objects (%s): %d frames, every count as derived" % (args.case, len(result["frames"])))


if __name__ == "__main__":
    main()

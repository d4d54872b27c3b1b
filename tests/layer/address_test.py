#!/usr/bin/env python3
"""Buffer device addresses under the Vulkan layer (docs/layer.md, "Buffer
device addresses"), on lavapipe:

  address_test.py --build BUILD_DIR

address_app.cpp reaches its buffers only through buffer_reference pointers.
Each frame is one compute pass of 256 invocations, 4-byte words, so by hand:

  "bda read":       256 reads of src[i], and 64 of middle[i] (an address 128
                    words into the same buffer): 320 reads, 1280 bytes;
  "bda written":    256 writes, 1024 bytes;
  "bda read-write": both[i] += for every i, and again for i < 64: 320 reads
                    and 320 writes, 1280 bytes each;
  "bda scratch":    64 writes, 256 bytes, in a buffer made, bound with
                    vkBindBufferMemory2, addressed and destroyed every frame
                    (the address table changes between submissions).

No "unknown address" line: every address the application uses lies in a
buffer whose address it took (lavapipe has neither sparse binding nor
capture replay, the paths by which a legitimate address escapes the layer:
address_search.cpp runs the instrumented search on the device with a
hand-built table that leaves buffers out, and tests/unit/spirv_address_test.cpp
the host's table). The lines sum to the accesses a single physical-storage-buffer
line per width would count. Both counting modes; and the run under the
Khronos validation layer, stacked with Tally's both ways, gives no message
that validation alone does not.
"""
import argparse
import json
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "support"))
from strict import skip_or_fail  # noqa: E402
sys.path.insert(0, HERE)
import validation  # noqa: E402
from layer_test import fail, load, run  # noqa: E402

FRAMES, SKIP = 3, 1
EXPECTED = {
    ("bda read", "read"): (320, 1280),
    ("bda written", "write"): (256, 1024),
    ("bda read-write", "read"): (320, 1280),
    ("bda read-write", "write"): (320, 1280),
    ("bda scratch", "write"): (64, 256),
}


def tally_env(build, output, mode):
    return {
        "VK_ADD_LAYER_PATH": os.path.join(build, "layer"),
        "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters",
        "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters",
        "TALLY_LAYER_OUTPUT": output,
        "TALLY_LAYER_FRAMES": str(FRAMES),
        "TALLY_LAYER_SKIP_FRAMES": str(SKIP),
        "TALLY_LAYER_FRAME_SUBMITS": "1",
        "TALLY_LAYER_COUNTING": mode,
    }


def check(result, what):
    indices = [f["index"] for f in result["frames"]]
    if indices != list(range(SKIP, SKIP + FRAMES)):
        fail("%s: frames %s, expected %s" % (what, indices, list(range(SKIP, SKIP + FRAMES))))
    for f in result["frames"]:
        if [p["name"] for p in f["passes"]] != ["by address"]:
            fail("%s frame %d: passes %s, expected 'by address'" % (what, f["index"], [p["name"] for p in f["passes"]]))
        p = f["passes"][0]
        if p["compute_invocations"] != 256:
            fail("%s frame %d: %d invocations, expected 256" % (what, f["index"], p["compute_invocations"]))
        got = {}
        for r in p["resources"]:
            key = (r["name"], r["access"])
            if key in got or r["kind"] != "buffer":
                fail("%s frame %d: line %s (%s) twice or not a buffer" % (what, f["index"], key, r["kind"]))
            got[key] = (r["count"], r["bytes"])
        if got != EXPECTED:
            fail("%s frame %d: lines %s, expected %s" % (what, f["index"], sorted(got.items()), sorted(EXPECTED.items())))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    args = parser.parse_args()
    build = os.path.abspath(args.build)
    app = [os.path.join(build, "tests", "layer", "tally_layer_address_app"), "--frames", str(SKIP + FRAMES + 1)]
    with tempfile.TemporaryDirectory(prefix="tally-addresses-") as tmp:
        for mode in ("exact", "accumulate"):
            out = os.path.join(tmp, mode + ".json")
            env = dict(os.environ)
            env.update(tally_env(build, out, mode))
            run(app, env=env)
            result = load(out)
            check(result, mode)
        print("addresses: every buffer's line is its accesses x 4 bytes, exact and accumulate, %d frames" % FRAMES)
        env = dict(os.environ)
        env.update({k: v for k, v in tally_env(build, "", "exact").items() if k.startswith("VK_")})
        tally_only = {k: v for k, v in tally_env(build, "", "exact").items() if k.startswith("TALLY_")}
        try:
            found, processes, _ = validation.run_stacks(app, env, tmp, os.path.join(build, "layer"), tally_only)
        except validation.RunError as e:
            skip_or_fail(str(e))
            return
        for name, p in processes.items():
            if p.returncode != 0:
                fail("%s: address_app exited %d\n%s" % (name, p.returncode, validation.tail(p.stderr)))
        for index, name in enumerate(validation.STACKS):
            if name != "validation":
                check(load(os.path.join(tmp, "tally-%d.json" % index)), name)
        extra = validation.defects(found)
        if extra:
            fail("messages only with Tally's layer: %s" % extra)
        print("addresses under validation: %s" % validation.summary(found))


if __name__ == "__main__":
    main()

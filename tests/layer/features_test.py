#!/usr/bin/env python3
"""The layer (docs/layer.md) on the Vulkan features its first version did not
resolve, on lavapipe:

  push-descriptors  graphics_app's fragment set bound, pushed with
                    vkCmdPushDescriptorSetKHR and with a push template, at set
                    0 and at set 1: every line named by its resource, counted
                    as W x H fragments dictate, and equal across the three.
  pipeline-library  graphics_app's pipeline monolithic, linked from four
                    graphics pipeline libraries, and from libraries with
                    independent-sets layouts: the same lines as monolithic.
  indirect          indexed indirect draws whose parameters a compute shader
                    writes (and their count): the derived index reads equal
                    the sum of indexCount x instanceCount over the draws.
  debug-names       compute_app calls vkSetDebugUtilsObjectNameEXT without
                    enabling VK_EXT_debug_utils: the validation layer reports
                    it as often alone as with this layer above or below it.
  submissions       graphics_app submitting with vkQueueSubmit and
                    vkQueueSubmit2, with a fence and without one: the same
                    lines in every frame, as W x H fragments dictate; without
                    a fence every readback rides in the application's own
                    submission, with one none does.
  libplacebo        ffmpeg's libplacebo filter, which pushes its planes with
                    vkCmdPushDescriptorSetWithTemplateKHR: every line named by
                    a resource, none by its set and binding.

  features_test.py --build BUILD_DIR --case NAME

Counts come from the frame size and the draws the test asks for, or from a
second run of the same application, never from a stored number.
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
from layer_test import fail, load, run  # noqa: E402

WIDTH, HEIGHT = 96, 64  # graphics_app's default target
VALIDATION_MANIFESTS = "/usr/share/vulkan/explicit_layer.d"


def layer_env(build, output, frames=2, skip=1):
    env = dict(os.environ)
    env.update({
        "VK_ADD_LAYER_PATH": os.path.join(build, "layer"),
        "VK_INSTANCE_LAYERS": "VK_LAYER_TALLY_counters",
        "VK_LOADER_LAYERS_ENABLE": "VK_LAYER_TALLY_counters",
        "TALLY_LAYER_OUTPUT": output,
        "TALLY_LAYER_FRAMES": str(frames),
        "TALLY_LAYER_STATISTICS_FRAMES": "all",
        "TALLY_LAYER_SKIP_FRAMES": str(skip),
        "TALLY_LAYER_FRAME_SUBMITS": "1",
    })
    return env


def graphics(build, tmp, name, *flags):
    """graphics_app under the layer: its output and the hash of its image."""
    out = os.path.join(tmp, name + ".json")
    app = os.path.join(build, "tests", "layer", "tally_layer_graphics_app")
    result = run([app, "--frames", "3"] + list(flags), env=layer_env(build, out))
    image = re.search(r"image hash ([0-9a-f]+)", result.stdout)
    return load(out), image.group(1) if image else None


def draw_passes(out, what):
    """Each frame's one pass with draws (graphics_app draws in one scope)."""
    found = []
    for f in out["frames"]:
        passes = [p for p in f["passes"] if p["draws"] > 0]
        if len(passes) != 1:
            fail("%s: frame %d has %d passes with draws, expected one" % (what, f["index"], len(passes)))
        found.append(passes[0])
    return found


def lines(p):
    return {(r["name"], r["access"], r["source"]): (r["count"], r["bytes"]) for r in p["resources"]}


def check_quad(p, what):
    """One full-screen quad of W x H: each fragment samples 'checker' (RGBA8),
    reads 'tint' (a vec4) and writes 'target' (RGBA8) once; each vertex reads
    'offset' (a vec4) and 'quad' (a vec2); six 16-bit indices."""
    fragments = WIDTH * HEIGHT
    got = lines(p)
    vertices = p["vertex_invocations"]
    expected = {
        ("checker", "read", "counter"): (fragments, fragments * 4),
        ("tint", "read", "counter"): (fragments, fragments * 16),
        ("target", "write", "counter"): (fragments, fragments * 4),
        ("offset", "read", "counter"): (vertices, vertices * 16),
        ("quad", "read", "counter"): (vertices, vertices * 8),
        ("indices", "read", "derived"): (6, 12),
    }
    if got != expected or p["fragment_invocations"] != fragments or vertices < 4:
        fail("%s: lines %s, fragments %d, vertices %d; expected %s with %d fragments" %
             (what, got, p["fragment_invocations"], vertices, expected, fragments))
    if not fragments <= p["fragment_invocations_statistic"]:
        fail("%s: the statistic %d is below the %d fragments counted" % (what, p["fragment_invocations_statistic"], fragments))


def case_push_descriptors(build, tmp):
    for push_set in ("0", "1"):
        reference, reference_image = graphics(build, tmp, "sets" + push_set, "--push-set", push_set)
        for p in draw_passes(reference, "sets"):
            check_quad(p, "descriptor sets, set " + push_set)
        for mode in ("push", "push-template"):
            what = "%s at set %s" % (mode, push_set)
            out, image = graphics(build, tmp, mode + push_set, "--descriptors", mode, "--push-set", push_set)
            for p in draw_passes(out, what):
                check_quad(p, what)
            if image != reference_image:
                fail("%s: the image differs from the bound sets' (%s, %s)" % (what, image, reference_image))
    print("push-descriptors: pushed and templated sets at 0 and 1 resolve to their resources, %d fragments" %
          (WIDTH * HEIGHT))


def case_pipeline_library(build, tmp):
    mono, mono_image = graphics(build, tmp, "monolithic")
    reference = draw_passes(mono, "monolithic")[-1]
    check_quad(reference, "monolithic")
    for kind in ("library", "library-independent"):
        for push_set in ("0", "1"):
            what = "%s, fragment set %s" % (kind, push_set)
            out, image = graphics(build, tmp, kind + push_set, "--pipeline", kind, "--push-set", push_set,
                                  "--descriptors", "push" if push_set == "1" else "sets")
            p = draw_passes(out, what)[-1]
            check_quad(p, what)
            if lines(p) != lines(reference) or image != mono_image:
                fail("%s: %s (image %s) differs from the monolithic %s (image %s)" %
                     (what, lines(p), image, lines(reference), mono_image))
            layer = out["layer"]
            if layer.get("pipeline_libraries") != 4 or layer.get("pipelines_linked") != 1:
                fail("%s: the layer saw %s libraries and %s linked pipelines, expected 4 and 1" %
                     (what, layer.get("pipeline_libraries"), layer.get("pipelines_linked")))
            stages = {(s["stage"], s["instrumented"]) for s in out["shaders"]}
            if ("vertex", True) not in stages or ("fragment", True) not in stages:
                fail("%s: the libraries' stages were not instrumented: %s" % (what, out["shaders"]))
    print("pipeline-library: linked pipelines count as the monolithic one (%d fragments)" % (WIDTH * HEIGHT))


def case_indirect(build, tmp):
    draws = [(6, 3), (3, 1), (6, 2)]
    spec = ",".join("%dx%d" % d for d in draws)
    indices = sum(n * instances for n, instances in draws)
    for mode in ("indirect", "indirect-count"):
        out, _ = graphics(build, tmp, mode, "--draw", mode, "--indirect-draws", spec)
        for f in out["frames"]:
            derived = [r for p in f["passes"] for r in p["resources"] if r["source"] == "derived"]
            if [(r["name"], r["count"], r["bytes"]) for r in derived] != [("indices", indices, indices * 2)]:
                fail("%s frame %d: derived lines %s, expected 'indices' %d x 2 bytes (%s)" %
                     (mode, f["index"], derived, indices, spec))
        if any("not derived" in n for n in out["notes"]):
            fail("%s: a note says index reads were not derived: %s" % (mode, out["notes"]))
    print("indirect: %d indices derived from %s written by a compute shader, with and without a count buffer" %
          (indices, spec))


def case_submissions(build, tmp):
    reference = None
    for how in ("fence", "none", "submit2-fence", "submit2-none"):
        out, image = graphics(build, tmp, "submit-" + how, "--submit", how)
        passes = draw_passes(out, how)
        if len(passes) != 2:  # layer_env's window
            fail("%s: %d frames counted, expected 2" % (how, len(passes)))
        for p in passes:
            check_quad(p, "--submit " + how)
        if reference is None:
            reference = image
        elif image != reference:
            fail("%s: the image differs from the fenced submission's (%s, %s)" % (how, image, reference))
        layer = out["layer"]
        riding = 0 if how.endswith("fence") else layer["readbacks"]
        if layer["readbacks"] < 2 or layer["readbacks_riding"] != riding:
            fail("%s: %d of %d readbacks rode in the application's submissions, expected %d" %
                 (how, layer["readbacks_riding"], layer["readbacks"], riding))
    print("submissions: vkQueueSubmit and vkQueueSubmit2, fenced or not, count %d fragments a frame alike" %
          (WIDTH * HEIGHT))


def loader_stack(stderr):
    """The device's layers, application side first, as the loader reports them."""
    stack = stderr.split("vkCreateDevice layer callstack setup to:")[-1]
    return re.findall(r"^\S*LAYER:\s+(VK_LAYER_\w+)\s*$", stack, re.M)


def case_debug_names(build, tmp):
    """Validation must see the application's vkSetDebugUtilsObjectNameEXT
    calls without the extension as often with the layer as without it. The
    loader (1.3.239) stacks layers in the order it finds their manifests, so
    VK_ADD_LAYER_PATH's order picks which is on top; the test checks the stack
    the loader reports."""
    if not os.path.exists(os.path.join(VALIDATION_MANIFESTS, "VkLayer_khronos_validation.json")):
        skip_or_fail("the Khronos validation layer is not installed (vulkan-validationlayers)")
    app = os.path.join(build, "tests", "layer", "tally_layer_compute_app")
    ours = os.path.join(build, "layer")
    runs = {
        "validation alone": (VALIDATION_MANIFESTS, ["VK_LAYER_KHRONOS_validation"]),
        "tally above validation": (ours + ":" + VALIDATION_MANIFESTS,
                                   ["VK_LAYER_TALLY_counters", "VK_LAYER_KHRONOS_validation"]),
        "validation above tally": (VALIDATION_MANIFESTS + ":" + ours,
                                   ["VK_LAYER_KHRONOS_validation", "VK_LAYER_TALLY_counters"]),
    }
    counts = {}
    for what, (path, order) in runs.items():
        folder = os.path.join(tmp, what.replace(" ", "-"))
        os.makedirs(folder)
        log = os.path.join(folder, "validation.log")
        with open(os.path.join(folder, "vk_layer_settings.txt"), "w") as f:
            f.write("khronos_validation.debug_action = VK_DBG_LAYER_ACTION_LOG_MSG\n"
                    "khronos_validation.report_flags = error,warn\n"
                    "khronos_validation.enable_message_limit = false\n"
                    "khronos_validation.log_filename = %s\n" % log)
        env = layer_env(build, os.path.join(folder, "tally.json"))
        env.update({"VK_ADD_LAYER_PATH": path, "VK_INSTANCE_LAYERS": ":".join(order),
                    "VK_LOADER_LAYERS_ENABLE": ",".join(order), "VK_LAYER_SETTINGS_PATH": folder,
                    "VK_LOADER_DEBUG": "layer"})
        result = run([app, "--frames", "5", "--debug-utils", "0"], env=env)
        stack = [name for name in loader_stack(result.stdout + result.stderr) if name in order]
        if stack != order:
            fail("%s: the loader stacked %s, expected %s" % (what, stack, order))
        if not os.path.exists(log):
            fail("%s: the validation layer wrote no log at %s" % (what, log))
        with open(log) as f:
            counts[what] = len(re.findall(r"Attempted to call vkSetDebugUtilsObjectNameEXT\(\) but its required "
                                          r"extension VK_EXT_debug_utils has not been enabled", f.read()))
    if counts["validation alone"] == 0:
        fail("the validation layer alone reported no call without the extension: the test proves nothing")
    if len(set(counts.values())) != 1:
        fail("validation messages differ with the layer: %s" % counts)
    print("debug-names: %s" % counts)


def case_libplacebo(build, tmp):
    if shutil.which("ffmpeg") is None:
        skip_or_fail("ffmpeg is not installed")
    out = os.path.join(tmp, "libplacebo.json")
    run(["ffmpeg", "-hide_banner", "-loglevel", "error", "-init_hw_device", "vulkan=vk:0", "-filter_hw_device", "vk",
         "-f", "lavfi", "-i", "testsrc=size=320x240:rate=10", "-frames:v", "10", "-vf",
         "format=yuv420p,hwupload,libplacebo=w=160:h=120:format=yuv420p,hwdownload,format=yuv420p", "-f", "null", "-"],
        env=layer_env(build, out, frames=2, skip=2))
    result = load(out)
    draws = 0
    for f in result["frames"]:
        for p in f["passes"]:
            draws += p["draws"]
            for r in p["resources"]:
                if re.match(r"set \d+ binding \d+$", r["name"]) or r["name"] == "unresolved":
                    fail("frame %d, pass %s: a line named by its binding, not a resource: %s" % (f["index"], p["name"], r))
                if r["count"] > 0 and r["bytes"] == 0:
                    fail("frame %d, pass %s: %s counts %d accesses of 0 bytes" % (f["index"], p["name"], r["name"], r["count"]))
    if draws == 0:
        fail("libplacebo drew nothing under the layer")
    print("libplacebo: every line of %d draws named by its resource" % draws)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    parser.add_argument("--case", required=True,
                        choices=["push-descriptors", "pipeline-library", "indirect", "debug-names", "libplacebo",
                                 "submissions"])
    args = parser.parse_args()
    build = os.path.abspath(args.build)
    with tempfile.TemporaryDirectory(prefix="tally-layer-features-") as tmp:
        {"push-descriptors": case_push_descriptors, "pipeline-library": case_pipeline_library,
         "indirect": case_indirect, "debug-names": case_debug_names,
         "libplacebo": case_libplacebo, "submissions": case_submissions}[args.case](build, tmp)


if __name__ == "__main__":
    main()

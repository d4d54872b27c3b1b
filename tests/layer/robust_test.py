#!/usr/bin/env python3
"""The Vulkan layer (docs/layer.md) under applications that stress its model,
on lavapipe: robust_app.cpp and swapchain_app.cpp, whose counts are derived
here from their dispatch sizes and extents alone.

  robust_test.py --build BUILD_DIR --case threads|devices|resize|reuse|prerecorded|steady|window|many|timing|oneshot

- threads: two threads, each with its own command pool, record and submit at
  once (on two queues where the device has them; lavapipe has one, which
  they share under the application's lock); every frame has both passes with
  their own counts.
- devices: two VkDevices used in turn; each writes its own output, and says
  which device it was.
- resize: a swapchain recreated at another size; each frame counts the
  extent it rendered at.
- reuse: one command buffer recorded before the window and submitted every
  frame; every counted frame is one submission's work (the readback zeroes
  the counters).
- prerecorded: command buffers recorded with ONE_TIME_SUBMIT before the
  window: the layer cannot count them, leaves those frames out and says so.
- steady: 10,000 frames, three in flight; the layer's heap stays bounded and
  it never waits for a readback, with few frames kept and with all of them.
- many: 600 dispatches in one recording, each into its own buffer: 600
  counter regions over more than one arena chunk, read back as merged
  ranges; every buffer's line has its own dispatch's count, in every frame
  (the readback zeroes every region it read).
- oneshot: a command buffer allocated and freed every frame: each frame
  counts its own fill, the layer never waits for a readback, and it uses
  its query pools again instead of creating two per command buffer.
- timing: TALLY_LAYER_TIMING=timestamps and none leave the counts as they
  are and drop the statistics (and the timestamps); a value it does not
  know turns counting off and says why. TALLY_LAYER_COUNTING=off times the
  same passes and counts nothing. By default only the window's first frame
  queries pipeline statistics (TALLY_LAYER_STATISTICS_FRAMES).
- window: before skip_frames ends, and without an output, the layer adds
  nothing to the application's command buffers and queues.
"""
import argparse
import json
import os
import re
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from layer_test import fail, layer_env, load, run, statistic  # noqa: E402
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from strict import skip_or_fail  # noqa: E402


def app(build):
    return os.path.join(build, "tests", "layer", "tally_layer_robust_app")


def check_fill(p, invocations, buffer, what):
    """A pass of the fill kernel: one invocation and one 4-byte write each."""
    if p["compute_invocations"] != invocations or p["dispatches"] != 1:
        fail("%s: %d invocations in %d dispatches, expected %d in 1" %
             (what, p["compute_invocations"], p["dispatches"], invocations))
    if statistic(p, "compute_invocations_statistic", what) != invocations:
        fail("%s: statistic %d, expected %d" % (what, p["compute_invocations_statistic"], invocations))
    writes = [r for r in p["resources"] if r["access"] == "write"]
    if len(writes) != 1 or writes[0]["name"] != buffer or writes[0]["count"] != invocations or \
            writes[0]["bytes"] != invocations * 4:
        fail("%s: writes %s, expected %d of 4 bytes to '%s'" % (what, writes, invocations, buffer))


def case_threads(build, tmp):
    out = os.path.join(tmp, "threads.json")
    result = run([app(build), "--mode", "threads", "--frames", "10"],
                 env=layer_env(build, out, frames=5, skip=2, frame_submits=2))
    queues = re.search(r"threads on (\d+) queue", result.stdout).group(1)
    counted = load(out)
    if [f["index"] for f in counted["frames"]] != [2, 3, 4, 5, 6]:
        fail("frames %s, expected 2..6" % [f["index"] for f in counted["frames"]])
    for f in counted["frames"]:
        passes = {p["name"]: p for p in f["passes"]}
        if f["submissions"] != 2 or set(passes) != {"thread 0", "thread 1"}:
            fail("frame %d: %d submissions, passes %s; expected one of each thread" %
                 (f["index"], f["submissions"], sorted(passes)))
        check_fill(passes["thread 0"], 1280, "out 0", "frame %d thread 0" % f["index"])
        check_fill(passes["thread 1"], 2240, "out 1", "frame %d thread 1" % f["index"])
    print("threads: %s queue(s), 5 frames of two concurrent submissions, each thread's counts its own" % queues)


def case_devices(build, tmp):
    out = os.path.join(tmp, "devices.json")
    run([app(build), "--mode", "devices", "--frames", "10"], env=layer_env(build, out, frames=3, skip=1, frame_submits=1))
    # Frame f runs on device f % 2: each device has 5 frames of its own.
    for index, path, invocations in ((0, out, 640), (1, os.path.join(tmp, "devices.device1.json"), 1920)):
        counted = load(path)
        if counted["device"].get("index") != index:
            fail("%s: device index %s, expected %d" % (path, counted["device"].get("index"), index))
        if [f["index"] for f in counted["frames"]] != [1, 2, 3]:
            fail("device %d: frames %s, expected 1..3 of its own" % (index, [f["index"] for f in counted["frames"]]))
        for f in counted["frames"]:
            if [p["name"] for p in f["passes"]] != ["fill"]:
                fail("device %d frame %d: passes %s" % (index, f["index"], [p["name"] for p in f["passes"]]))
            check_fill(f["passes"][0], invocations, "out", "device %d frame %d" % (index, f["index"]))
    print("devices: device 0 wrote devices.json (640 a frame), device 1 devices.device1.json (1920 a frame)")


def case_resize(build, tmp):
    if shutil.which("xvfb-run") is None:
        skip_or_fail("xvfb-run is not installed (scripts/setup.sh installs xvfb)")
    out = os.path.join(tmp, "resize.json")
    command = ["xvfb-run", "-a", os.path.join(build, "tests", "layer", "tally_layer_swapchain_app"), "--frames", "9",
               "--resize-after", "4", "--first", "96x64", "--second", "160x120"]
    result = run(command, env=layer_env(build, out, frames=6, skip=1))
    extents = {int(f): (int(w), int(h)) for f, w, h in re.findall(r"frame (\d+) extent (\d+)x(\d+)", result.stdout)}
    counted = load(out)
    indices = [f["index"] for f in counted["frames"]]
    if indices != [1, 2, 3, 4, 5, 6]:
        fail("frames %s, expected 1..6" % indices)
    if len(set(extents[i] for i in indices)) != 2:
        fail("the application did not render at two sizes: %s" % extents)
    for f in counted["frames"]:
        w, h = extents[f["index"]]
        p = f["passes"][0]
        if len(f["passes"]) != 1 or p["fragment_invocations"] != w * h:
            fail("frame %d at %dx%d: %d fragment invocations, expected %d" %
                 (f["index"], w, h, p["fragment_invocations"], w * h))
        writes = [r for r in p["resources"] if r["access"] == "write"]
        if len(writes) != 1 or writes[0]["name"] != "swapchain" or writes[0]["count"] != w * h:
            fail("frame %d: colour writes %s, expected %d to the swapchain" % (f["index"], writes, w * h))
        if statistic(p, "fragment_invocations_statistic", "frame %d" % f["index"]) < w * h:
            fail("frame %d: statistic %d below the %d pixels" % (f["index"], p["fragment_invocations_statistic"], w * h))
        if p["vertex_invocations"] != 3:
            fail("frame %d: %d vertex invocations, expected 3" % (f["index"], p["vertex_invocations"]))
    if counted["extent"] != list(extents[max(extents)]):
        fail("extent %s, expected the last swapchain's %s" % (counted["extent"], extents[max(extents)]))
    print("resize: frames at %s then %s counted at their own extents" % (extents[indices[0]], extents[indices[-1]]))


def case_reuse(build, tmp):
    out = os.path.join(tmp, "reuse.json")
    run([app(build), "--mode", "reuse", "--frames", "12"], env=layer_env(build, out, frames=5, skip=3, frame_submits=1))
    counted = load(out)
    if [f["index"] for f in counted["frames"]] != [3, 4, 5, 6, 7]:
        fail("frames %s, expected 3..7" % [f["index"] for f in counted["frames"]])
    for f in counted["frames"]:
        check_fill(f["passes"][0], 2560, "out", "frame %d" % f["index"])
    if counted["layer"]["frames_counted"] != 5 or counted["layer"]["frames_left_out"] != 0:
        fail("layer: %s" % counted["layer"])
    print("reuse: one recording before the window, submitted 12 times; frames 3..7 count one submission each")


def case_prerecorded(build, tmp):
    out = os.path.join(tmp, "prerecorded.json")
    run([app(build), "--mode", "prerecorded", "--frames", "12"],
        env=layer_env(build, out, frames=3, skip=3, frame_submits=1))
    if not os.path.exists(out):
        fail("the layer wrote no output")
    counted = json.load(open(out))
    layer = counted["layer"]
    # Recorded at frame 0 for one submission each, before the window's first
    # frame (3) was near: every frame from 3 to 11 ran them uncounted.
    if counted["complete"] or counted["frames"] or layer["frames_counted"] != 0 or layer["frames_wanted"] != 3 or \
            layer["frames_left_out"] != 9:
        fail("expected nothing counted and frames 3..11 left out: complete %s, %d frames, layer %s" %
             (counted["complete"], len(counted["frames"]), layer))
    if not any("9 frames of the window" in n and "recorded outside it" in n for n in counted["notes"]):
        fail("no note says why: %s" % counted["notes"])
    print("prerecorded: frames_counted 0 of 3 wanted, 9 frames left out, with the reason in the notes")


def steady(build, tmp, frames_kept):
    out = os.path.join(tmp, "steady-%d.json" % frames_kept)
    result = run([app(build), "--mode", "steady", "--frames", "10000"],
                 env=layer_env(build, out, frames=frames_kept, skip=1, frame_submits=1), timeout=600)
    heap = {int(f): int(b) for f, b in re.findall(r"memory at frame (\d+): rss \d+ KiB, heap (\d+) B", result.stdout)}
    counted = load(out)
    if len(counted["frames"]) != frames_kept or counted["layer"]["frames_counted"] != frames_kept:
        fail("%d frames kept, expected %d" % (len(counted["frames"]), frames_kept))
    for f in counted["frames"]:
        p = f["passes"][0]
        if p["compute_invocations"] != 256 or [(r["name"], r["count"]) for r in p["resources"]] != [("out", 256)]:
            fail("frame %d: %s" % (f["index"], p))
    # Three frames in flight and a ring of 64 readbacks: the layer never waits.
    if counted["layer"]["readback_waits"] != 0:
        fail("the layer waited for a readback %d times" % counted["layer"]["readback_waits"])
    return heap[10000] - heap[1000], counted


def case_steady(build, tmp):
    # Few frames kept: the window ends at frame 6; from frame 1000 to 10000 the
    # layer reads nothing and keeps nothing more. 64 KiB over 9,000 frames is
    # 7 bytes a frame: anything the layer kept per frame would show.
    growth, _ = steady(build, tmp, 5)
    if growth >= 64 * 1024:
        fail("with 5 frames kept, the heap grew %d bytes from frame 1000 to 10000 (bound 64 KiB)" % growth)
    # Every frame kept: each holds a frame record with one pass and one line
    # (about 460 bytes on lavapipe); 1 KiB a frame bounds it with the heap's rounding.
    growth_kept, counted = steady(build, tmp, 10000 - 1)
    kept = sum(1 for f in counted["frames"] if 1000 <= f["index"] < 10000)
    if growth_kept > 1024 * kept:
        fail("with every frame kept, the heap grew %d bytes over %d frames (bound 1 KiB a frame)" % (growth_kept, kept))
    print("steady: heap growth from frame 1000 to 10000: %d B with 5 frames kept, %d B (%d B a frame) with all kept; "
          "no readback waits" % (growth, growth_kept, growth_kept // kept))


def many(build, tmp, timing):
    out = os.path.join(tmp, "many-%s.json" % timing)
    env = layer_env(build, out, frames=3, skip=1, frame_submits=1)
    env["TALLY_LAYER_TIMING"] = timing
    run([app(build), "--mode", "many", "--frames", "5"], env=env)
    counted = load(out)
    if [f["index"] for f in counted["frames"]] != [1, 2, 3] or counted["layer"]["timing"] != timing:
        fail("timing %s: frames %s, layer.timing %r" %
             (timing, [f["index"] for f in counted["frames"]], counted["layer"]["timing"]))
    expected = {"out %d" % i: 64 * (i % 5 + 1) for i in range(600)}
    for f in counted["frames"]:
        passes = f["passes"]
        if len(passes) != 1 or passes[0]["name"] != "many" or passes[0]["dispatches"] != 600:
            fail("timing %s, frame %d: passes %s, expected one 'many' of 600 dispatches" %
                 (timing, f["index"], [(p["name"], p["dispatches"]) for p in passes]))
        p = passes[0]
        got = {r["name"]: r["count"] for r in p["resources"] if r["access"] == "write"}
        if got != expected:
            wrong = sorted(set(got.items()) ^ set(expected.items()))[:6]
            fail("timing %s, frame %d: %d write lines, expected 600; first differences %s" %
                 (timing, f["index"], len(got), wrong))
        if p["compute_invocations"] != sum(expected.values()):
            fail("timing %s, frame %d: %d invocations, expected %d" %
                 (timing, f["index"], p["compute_invocations"], sum(expected.values())))
    return counted["frames"][0]["passes"][0]


def case_many(build, tmp):
    p = many(build, tmp, "all")
    # A Vulkan 1.1 application: the layer enables no 64-bit atomics and counts in pairs of 32-bit words.
    bits = load(os.path.join(tmp, "many-all.json"))["layer"]["counter_bits"]
    if bits != 32:
        fail("many: a Vulkan 1.1 application counted with %d-bit counters, expected 32" % bits)
    total = 64 * 3 * 600
    if statistic(p, "compute_invocations_statistic", "many") != total or p["gpu_ms"] < 0:
        fail("many: statistic %s, gpu_ms %s; expected %d and a time" % (p["compute_invocations_statistic"], p["gpu_ms"],
                                                                         total))
    print("many: 600 regions in one recording, 3 frames, every line its dispatch's count; statistic %d" % total)


def case_oneshot(build, tmp):
    out = os.path.join(tmp, "oneshot.json")
    run([app(build), "--mode", "oneshot", "--frames", "40"], env=layer_env(build, out, frames=30, skip=5,
                                                                          frame_submits=1))
    counted = load(out)
    if [f["index"] for f in counted["frames"]] != list(range(5, 35)):
        fail("frames %s, expected 5..34" % [f["index"] for f in counted["frames"]])
    for f in counted["frames"]:
        check_fill(f["passes"][0], 2560, "out", "frame %d" % f["index"])
    layer = counted["layer"]
    # 40 command buffers, two pools each (timestamps, statistics) before;
    # now a freed one's pools wait for its readback, then serve again: a few
    # sets, however many frames.
    if layer["readback_waits"] != 0 or not 2 <= layer["query_pools"] <= 8:
        fail("oneshot: %d readback waits (expected 0), %d query pools created for 40 command buffers "
             "(expected 2 to 8)" % (layer["readback_waits"], layer["query_pools"]))
    print("oneshot: 40 command buffers freed after their fences; 30 frames counted; %d query pools, no wait" %
          layer["query_pools"])


def case_timing(build, tmp):
    timestamps = many(build, tmp, "timestamps")
    if timestamps["compute_invocations_statistic"] >= 0 or timestamps["gpu_ms"] < 0:
        fail("timing timestamps: statistic %s, gpu_ms %s; expected none and a time" %
             (timestamps["compute_invocations_statistic"], timestamps["gpu_ms"]))
    none = many(build, tmp, "none")
    if none["compute_invocations_statistic"] >= 0 or none["gpu_ms"] >= 0:
        fail("timing none: statistic %s, gpu_ms %s; expected neither" %
             (none["compute_invocations_statistic"], none["gpu_ms"]))
    # Counting off: the same passes, timed, with the application's own
    # pipeline (no line, no invocation counted), and the statistic as before.
    out = os.path.join(tmp, "off.json")
    env = layer_env(build, out, frames=3, skip=1, frame_submits=1)
    env["TALLY_LAYER_COUNTING"] = "off"
    run([app(build), "--mode", "many", "--frames", "5"], env=env)
    counted = load(out)
    total = 64 * 3 * 600
    for f in counted["frames"]:
        p = f["passes"][0]
        if p["name"] != "many" or p["resources"] or p["compute_invocations"] != 0 or p["gpu_ms"] < 0 or \
                statistic(p, "compute_invocations_statistic", "off") != total:
            fail("counting off, frame %d: %s" % (f["index"], {k: v for k, v in p.items() if k != "resources"}))
    if counted["layer"]["counting"] != "off" or len(counted["frames"]) != 3:
        fail("counting off: layer.counting %r, %d frames" % (counted["layer"]["counting"], len(counted["frames"])))
    # By default only the window's first frame queries statistics; 2 asks for two.
    for wanted, env_value in ((1, None), (2, "2")):
        out = os.path.join(tmp, "statistics-%d.json" % wanted)
        env = layer_env(build, out, frames=3, skip=1, frame_submits=1)
        del env["TALLY_LAYER_STATISTICS_FRAMES"]
        if env_value:
            env["TALLY_LAYER_STATISTICS_FRAMES"] = env_value
        run([app(build), "--mode", "many", "--frames", "5"], env=env)
        counted = load(out)
        got = [f["passes"][0]["compute_invocations_statistic"] for f in counted["frames"]]
        if got != [total] * wanted + [-1] * (3 - wanted) or counted["layer"]["statistics_frames"] != wanted:
            fail("statistics in the first %d frame(s): statistics %s, layer.statistics_frames %r" %
                 (wanted, got, counted["layer"]["statistics_frames"]))
        for f in counted["frames"]:
            if {r["name"]: r["count"] for r in f["passes"][0]["resources"]} != \
                    {"out %d" % i: 64 * (i % 5 + 1) for i in range(600)}:
                fail("statistics in the first %d frame(s): frame %d's counts differ" % (wanted, f["index"]))
    out = os.path.join(tmp, "bad.json")
    env = layer_env(build, out, frames=1, skip=0, frame_submits=1)
    env["TALLY_LAYER_TIMING"] = "sometimes"
    result = run([app(build), "--mode", "reuse", "--frames", "2"], env=env)
    said = json.load(open(out))["layer"]["not_counting"]
    if "TALLY_LAYER_TIMING: 'sometimes' is not all, timestamps or none" not in said + result.stderr:
        fail("an unknown TALLY_LAYER_TIMING: not_counting %r, stderr %r" % (said, result.stderr[-400:]))
    print("timing: timestamps and none count as all does; no statistic (and no time); 'sometimes' refused: %s" % said)


def case_window(build, tmp):
    # No output: the application's calls go straight to the driver.
    env = layer_env(build, "", frames=1, skip=0)
    del env["TALLY_LAYER_OUTPUT"]
    result = run([app(build), "--mode", "steady", "--frames", "300"], env=env)
    library = re.search(r"vkQueueSubmit is in (\S+)", result.stdout).group(1)
    if "VkLayer_tally" in os.path.basename(library):
        fail("without an output the application's vkQueueSubmit still enters the layer (%s)" % library)
    # An output, but the window never opens in 300 frames: the three slots'
    # command buffers count their first recording (it might be submitted
    # again, inside the window); the 297 recordings after it are the
    # application's own, with no readback.
    out = os.path.join(tmp, "window.json")
    result = run([app(build), "--mode", "steady", "--frames", "300"],
                 env=layer_env(build, out, frames=2, skip=1000, frame_submits=1))
    if "VkLayer_tally" not in result.stdout:
        fail("with an output, vkQueueSubmit does not enter the layer: %s" % result.stdout)
    counted = json.load(open(out))
    layer = counted["layer"]
    if counted["frames"] or layer["readbacks"] != 3 or layer["readback_waits"] != 0:
        fail("before the window: %d frames, %d readbacks (expected 3), %d waits" %
             (len(counted["frames"]), layer["readbacks"], layer["readback_waits"]))
    print("window: no output, the driver's vkQueueSubmit; before the window, 3 readbacks in 300 frames")


def main():
    cases = {"threads": case_threads, "devices": case_devices, "resize": case_resize, "reuse": case_reuse,
             "prerecorded": case_prerecorded, "steady": case_steady, "window": case_window, "many": case_many,
             "timing": case_timing, "oneshot": case_oneshot}
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", required=True)
    parser.add_argument("--case", required=True, choices=sorted(cases))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="tally-layer-robust-") as tmp:
        cases[args.case](os.path.abspath(args.build), tmp)


if __name__ == "__main__":
    main()

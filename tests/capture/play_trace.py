#!/usr/bin/env python3
"""`tallyd play` as a layer sees it: each renderer runs under the
GFXReconstruct capture layer (an ordinary layer that intercepts every Vulkan
call), and the trace (gfxrecon-convert's JSON lines) must show what a
bandwidth layer needs to compare its counts with `tallyd capture`'s:

- every frame is one vkQueueSubmit of one command buffer, the only
  submissions with draws or dispatches;
- that command buffer holds one debug label per pass, in the order of the
  passes, none nested, every draw and dispatch inside one;
- pipeline layouts hold at most kSetPassInput + 1 = 4 sets, none binds a
  set past them (no counter set);
- every resource the run lists is named, and every line the instrumented
  capture counts in a pass names an image or buffer the trace shows bound
  (descriptors, vertex and index buffers, attachments) at a draw or dispatch
  inside that pass's label.

Runs on "planes" and "atrium", and on Sponza (textures of many sizes,
alpha-masked materials) where its glTF file is given and exists. Prints one
line per renderer variant and scene. Exits 77 (skipped) where gfxreconstruct
is not installed.
Usage: play_trace.py TALLYD [SPONZA_GLTF]
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import defaultdict

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from strict import skip_or_fail, strict  # noqa: E402

MAX_SETS = 4  # shaders/shared.h kSetPassInput + 1
VARIANTS = [
    ("forward", {}),
    ("forward-zprepass", {}),
    ("deferred", {}),
    ("deferred", {"gbuffer": "subpass"}),
    ("deferred", {"shading": "compute", "shadows": "hard"}),
    ("visbuffer", {}),
    ("visbuffer", {"msaa": 4, "bloom": "separable"}),
    ("visbuffer-lean", {}),
    ("visbuffer-lean", {"lod": 2, "tangent_frame": "quaternion"}),
    ("volume-fog", {}),
    ("raytrace", {}),
]
SCENES = ["planes", "atrium"]
DRAWS = ("vkCmdDraw", "vkCmdDrawIndexed", "vkCmdDrawIndirect", "vkCmdDrawIndexedIndirect", "vkCmdDispatch",
         "vkCmdDispatchIndirect")


def layer_installed():
    if shutil.which("gfxrecon-convert") is None:
        return False
    for d in ("/usr/share/vulkan/explicit_layer.d", "/etc/vulkan/explicit_layer.d",
              "/usr/local/share/vulkan/explicit_layer.d"):
        if os.path.exists(os.path.join(d, "VkLayer_gfxreconstruct.json")):
            return True
    return False


# gfxrecon-convert writes non-finite floats bare (clear colours of all-ones uints).
NON_FINITE = re.compile(r"(?<=[\[,:])-?(?:nan|inf)(?=[,\]}])")


def calls(path):
    with open(path) as f:
        for line in f:
            entry = json.loads(NON_FINITE.sub("null", line))
            if "vkFunc" in entry:
                yield entry["vkFunc"]["name"], entry["vkFunc"].get("args", {})


class Trace:
    """Replays the calls that matter: objects, names, descriptors, and each
    submitted command buffer's commands with the state at every draw."""

    def __init__(self, path):
        self.names = {}                # object id -> name
        self.view_image = {}           # image view -> image
        self.framebuffer_views = {}    # framebuffer -> views
        self.descriptors = defaultdict(dict)  # set -> (binding, element) -> [objects]
        self.layout_sets = []          # setLayoutCount of every pipeline layout
        self.recording = defaultdict(list)    # command buffer -> [(name, args)]
        self.submits = []              # [[command buffer recordings]]
        for name, a in calls(path):
            if name == "vkSetDebugUtilsObjectNameEXT":
                self.names[a["pNameInfo"]["objectHandle"]] = a["pNameInfo"]["pObjectName"]
            elif name == "vkCreateImageView":
                self.view_image[a["pView"]] = a["pCreateInfo"]["image"]
            elif name == "vkCreateFramebuffer":
                self.framebuffer_views[a["pFramebuffer"]] = a["pCreateInfo"]["pAttachments"] or []
            elif name == "vkCreatePipelineLayout":
                self.layout_sets.append(a["pCreateInfo"]["setLayoutCount"])
            elif name == "vkUpdateDescriptorSets":
                for w in a.get("pDescriptorWrites") or []:
                    objects = []
                    for info in w.get("pImageInfo") or []:
                        if info.get("imageView"):
                            objects.append(self.view_image.get(info["imageView"]))
                    for info in w.get("pBufferInfo") or []:
                        objects.append(info.get("buffer"))
                    for i, o in enumerate(objects):
                        self.descriptors[w["dstSet"]][(w["dstBinding"], w["dstArrayElement"] + i)] = [o]
            elif name == "vkBeginCommandBuffer":
                self.recording[a["commandBuffer"]] = []
            elif name.startswith("vkCmd"):
                self.recording[a["commandBuffer"]].append((name, a))
            elif name == "vkQueueSubmit":
                for s in a.get("pSubmits") or []:
                    self.submits.append([list(self.recording[cb]) for cb in s.get("pCommandBuffers") or []])

    def reachable(self, state):
        """Names of the images and buffers a draw can reach."""
        objects = set()
        for bound in state["sets"].values():
            for s in bound.values():
                for objs in self.descriptors.get(s, {}).values():
                    objects.update(objs)
        objects.update(state["vertex"])
        if state["index"] is not None:
            objects.add(state["index"])
        for view in self.framebuffer_views.get(state["framebuffer"], []):
            objects.add(self.view_image.get(view))
        return {self.names[o] for o in objects if o in self.names}

    def frame(self, commands):
        """Labels in order, problems, and per label the names reachable at its draws."""
        labels, problems = [], []
        reached = defaultdict(set)
        open_label = None
        state = {"sets": defaultdict(dict), "vertex": set(), "index": None, "framebuffer": None}
        for name, a in commands:
            if name == "vkCmdBeginDebugUtilsLabelEXT":
                if open_label is not None:
                    problems.append(f"label {a['pLabelInfo']['pLabelName']} opened inside {open_label}")
                open_label = a["pLabelInfo"]["pLabelName"]
                labels.append(open_label)
            elif name == "vkCmdEndDebugUtilsLabelEXT":
                if open_label is None:
                    problems.append("a label closed that was not open")
                open_label = None
            elif name == "vkCmdBindDescriptorSets":
                last = a["firstSet"] + a["descriptorSetCount"]
                if last > MAX_SETS:
                    problems.append(f"binds sets {a['firstSet']}..{last - 1}")
                for i, s in enumerate(a["pDescriptorSets"] or []):
                    state["sets"][a["pipelineBindPoint"]][a["firstSet"] + i] = s
            elif name == "vkCmdBindVertexBuffers":
                state["vertex"].update(a["pBuffers"] or [])
            elif name == "vkCmdBindIndexBuffer":
                state["index"] = a["buffer"]
            elif name == "vkCmdBeginRenderPass":
                state["framebuffer"] = a["pRenderPassBegin"]["framebuffer"]
            elif name == "vkCmdEndRenderPass":
                state["framebuffer"] = None
            elif name in DRAWS:
                if open_label is None:
                    problems.append(f"{name} outside every label")
                else:
                    reached[open_label] |= self.reachable(state)
        if open_label is not None:
            problems.append(f"label {open_label} never closed")
        return labels, problems, reached


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def check(tallyd, work, renderer, options, scene):
    shown = scene if isinstance(scene, str) else os.path.basename(scene.get("gltf", json.dumps(scene)))
    tag = f"{renderer} {json.dumps(options)} {shown}"
    problems = []
    is_workload = renderer in ("volume-fog", "raytrace")
    entry = {"workload" if is_workload else "renderer": renderer, "options": options}
    spec = {"workloads" if is_workload else "renderers": [entry], "scenes": [scene], "resolutions": [[64, 36]],
            "frames": 1, "counted_frames": 1, "lights": 8, "ceilings": False}
    spec_path = os.path.join(work, "spec.json")
    result_path = os.path.join(work, "result.json")
    with open(spec_path, "w") as f:
        json.dump(spec, f)
    c = run([tallyd, "capture", "--quiet", "--spec", spec_path, "--out", result_path])
    if c.returncode != 0:
        return tag, [f"capture failed: {c.stderr.strip()}"], None
    with open(result_path) as f:
        sample = json.load(f)["runs"][0]["samples"][0]  # camera 0 of the automatic set, as play's default

    trace = os.path.join(work, "play.gfxr")
    env = dict(os.environ, VK_INSTANCE_LAYERS="VK_LAYER_LUNARG_gfxreconstruct", GFXRECON_CAPTURE_FILE=trace,
               GFXRECON_CAPTURE_FILE_TIMESTAMP="false", GFXRECON_LOG_LEVEL="error")
    frames = 2
    scene_arg = scene if isinstance(scene, str) else json.dumps(scene)
    p = run([tallyd, "play", "--renderer", renderer, "--options", json.dumps(options), "--scene", scene_arg,
             "--resolution", "64x36", "--frames", str(frames), "--lights", "8", "--json", "--quiet"], env=env)
    if p.returncode != 0:
        return tag, [f"play exited {p.returncode}: {p.stderr.strip()}"], None
    summary = json.loads(p.stdout.strip().splitlines()[-1])
    jsonl = os.path.join(work, "play.jsonl")
    c = run(["gfxrecon-convert", "--output", jsonl, trace])
    if c.returncode != 0:
        return tag, [f"gfxrecon-convert failed: {c.stderr.strip()}"], None
    t = Trace(jsonl)

    if max(t.layout_sets, default=0) > MAX_SETS:
        problems.append(f"a pipeline layout of {max(t.layout_sets)} sets")
    named = set(t.names.values())
    for r in summary["named"]:
        if r["name"] not in named:
            problems.append(f"resource {r['name']} never named")
    drawing_at = [i for i, s in enumerate(t.submits) if any(n in DRAWS for cb in s for n, _ in cb)]
    drawing = [t.submits[i] for i in drawing_at]
    if len(drawing) != frames:
        problems.append(f"{len(drawing)} submissions draw or dispatch, expected one per frame ({frames})")
    for s in drawing:
        if len(s) != 1:
            problems.append(f"a frame submission of {len(s)} command buffers")
            continue
        labels, frame_problems, reached = t.frame(s[0])
        problems += frame_problems
        if labels != summary["passes"]:
            problems.append(f"labels {labels} != passes {summary['passes']}")
        for p in sample["passes"]:
            for line in p["resources"]:
                if line["name"] not in reached[p["name"]]:
                    problems.append(f"{p['name']}: line {line['access']} {line['name']} ({line['source']}) "
                                    f"not bound under that name in the pass's label")
    # From the first frame on, nothing but the frames is submitted (no uploads or read-backs between them).
    first = drawing_at[0] if drawing_at else len(t.submits)
    if len(t.submits) - first != frames:
        problems.append(f"{len(t.submits) - first} submissions from the first frame on, expected {frames}")
    return tag, sorted(set(problems)), {"drawing": len(drawing) / frames, "labels": summary["passes"]}


def main():
    if len(sys.argv) < 2:
        print(__doc__)
        return 2
    if not layer_installed():
        skip_or_fail("gfxreconstruct (VkLayer_gfxreconstruct, gfxrecon-convert) is not installed")
    tallyd = os.path.realpath(sys.argv[1])
    runs = [(scene, variant) for scene in SCENES for variant in VARIANTS]
    sponza = sys.argv[2] if len(sys.argv) > 2 else ""
    if sponza and os.path.exists(sponza):
        scene = {"gltf": os.path.realpath(sponza), "max_texture_size": 64}
        runs += [(scene, (name, {})) for name in ("forward", "forward-zprepass", "deferred", "visbuffer",
                                                  "visbuffer-lean")]
    elif sponza:
        if strict():
            print(f"FAIL: no Sponza at {sponza} (required where CI=true or TALLY_TEST_STRICT=1)")
            return 1
        print(f"no Sponza at {sponza}: planes and atrium only")
    failed = False
    with tempfile.TemporaryDirectory() as work:
        for scene, (renderer, options) in runs:
            tag, problems, info = check(tallyd, work, renderer, options, scene)
            if problems:
                failed = True
                print(f"FAIL {tag}")
                for p in problems:
                    print(f"     {p}")
            else:
                print(f"ok   {tag}: {info['drawing']:.0f} submission per frame, labels {' '.join(info['labels'])}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

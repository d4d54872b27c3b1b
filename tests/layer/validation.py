"""The Khronos validation layer stacked with Tally's, in both orders, against
validation alone: a message that appears only where Tally's layer is loaded
is the layer's defect (docs/layer.md, "How the layer is tested").

Validation is configured by a vk_layer_settings.txt found through
VK_LAYER_SETTINGS_PATH (the 1.3.239 layer's manifest names environment
variables for some settings, none for a log file): SETTINGS below, the one
place the settings are listed.
"""
import collections
import json
import os
import re
import subprocess

VALIDATION = "VK_LAYER_KHRONOS_validation"
TALLY = "VK_LAYER_TALLY_counters"

# Core checks (object lifetimes, parameters, state, shaders: the layer's
# defaults), thread safety turned back on (the default turns it off; Tally's
# layer calls the device from whichever application thread submits),
# synchronization validation (Tally's layer adds copies, fills and
# submissions of its own), every report kind but information, and no message
# limit (the default reports the first ten of each id).
SETTINGS = {
    "khronos_validation.debug_action": "VK_DBG_LAYER_ACTION_LOG_MSG",
    "khronos_validation.report_flags": "error,warn,perf",
    "khronos_validation.enable_message_limit": "false",
    "khronos_validation.disables": "",
    "khronos_validation.enables": "VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT",
}

# The three stacks, nearest the application first (the loader's order).
STACKS = {
    "validation": [VALIDATION],
    "validation, then tally": [VALIDATION, TALLY],
    "tally, then validation": [TALLY, VALIDATION],
}

# "VUID-...(ERROR / SPEC): msgNum: 123 - ..." opens each message in the log.
HEADER = re.compile(r"^(\S+)\((\w+) / (\w+)\): msgNum: (-?\d+)")
LEAKED = re.compile(r"Object 1: handle = 0x[0-9a-f]+, type = (VK_OBJECT_TYPE_\w+)")


def settings_file(folder, log):
    path = os.path.join(folder, "vk_layer_settings.txt")
    with open(path, "w") as f:
        for key, value in SETTINGS.items():
            f.write("%s = %s\n" % (key, value))
        f.write("khronos_validation.log_filename = %s\n" % log)
    return path


def messages(log):
    """({key: count}, {key: its first message's line}): the key is the
    message id (VUID or the layer's name for it), and for an object left
    undestroyed the object's type too, so that a handle Tally's layer leaks
    is not hidden among the application's own leaks."""
    counts, first = collections.Counter(), {}
    if not os.path.exists(log):
        return counts, first
    with open(log, errors="replace") as f:
        for line in f:
            m = HEADER.match(line)
            if not m:
                continue
            key = m.group(1)
            leaked = LEAKED.search(line) if "has not been destroyed" in line else None
            if leaked:
                key += " " + leaked.group(1)
            counts[key] += 1
            first.setdefault(key, line.strip()[:600])
    return counts, first


def manifest_folder(name, extra=()):
    """The folder of a layer's manifest: `extra` folders first, then the
    loader's system folders."""
    manifest = {VALIDATION: "VkLayer_khronos_validation.json", TALLY: "VkLayer_tally_counters.json"}[name]
    data_dirs = os.environ.get("XDG_DATA_DIRS", "/usr/local/share:/usr/share").split(":")
    folders = list(extra) + [os.path.join(d, "vulkan", "explicit_layer.d") for d in data_dirs + ["/etc"]]
    for folder in folders:
        if os.path.exists(os.path.join(folder, manifest)):
            return folder
    return None


def device_chain(stderr):
    """The layers of each vkCreateDevice's chain in the loader's debug output
    (VK_LOADER_DEBUG=layer), nearest the application first."""
    chains, current = [], None
    for line in stderr.splitlines():
        if "vkCreateDevice layer callstack setup to" in line:
            current = []
            chains.append(current)
        elif current is not None:
            m = re.match(r"^LAYER:\s+(VK_LAYER_\w+)\s*$", line)
            if m and m.group(1) in (VALIDATION, TALLY):
                current.append(m.group(1))
            elif "<Drivers>" in line or "<Device>" in line:
                current = None
    return chains


class RunError(Exception):
    """A run that cannot be compared: the layers were not stacked as asked,
    or Tally's layer wrote no output."""


def run_stacks(command, env, folder, tally_dir, tally_env, timeout=300):
    """Runs `command` once per stack, in `folder`; returns ({stack: {key:
    count}}, {stack: completed process}, {stack: first line of each key}).
    `tally_env` is added where Tally's layer is in the stack, with
    TALLY_LAYER_OUTPUT set here: the output must appear, counting, which shows
    the layer ran the whole application.

    The 1.3.239 loader stacks the layers VK_INSTANCE_LAYERS names in the
    order their manifests' folders are searched, not in the order named: so
    VK_LAYER_PATH lists the folders in the stack's order too, and each run's
    loader debug output must show the device's chain in that order."""
    validation_dir = manifest_folder(VALIDATION)
    if validation_dir is None:
        raise RunError("the Khronos validation layer is not installed (Debian: vulkan-validationlayers)")
    folders = {VALIDATION: validation_dir, TALLY: tally_dir}
    found, processes, first = {}, {}, {}
    for index, (name, layers) in enumerate(STACKS.items()):
        log = os.path.join(folder, "validation-%d.log" % index)
        settings_dir = os.path.join(folder, "settings-%d" % index)
        os.makedirs(settings_dir, exist_ok=True)
        settings_file(settings_dir, log)
        output = os.path.join(folder, "tally-%d.json" % index)
        run_env = dict(env)
        run_env.pop("VK_ADD_LAYER_PATH", None)
        run_env.update({
            "VK_LAYER_SETTINGS_PATH": settings_dir,
            "VK_INSTANCE_LAYERS": ":".join(layers),
            "VK_LOADER_LAYERS_ENABLE": ",".join(layers),
            "VK_LAYER_PATH": ":".join(folders[layer] for layer in layers),
            "VK_LOADER_DEBUG": "layer",
        })
        if TALLY in layers:
            run_env.update(tally_env)
            run_env["TALLY_LAYER_OUTPUT"] = output
        p = subprocess.run(command, env=run_env, timeout=timeout, capture_output=True, text=True, cwd=folder)
        chains = device_chain(p.stderr)
        if not chains or any(c != layers for c in chains):
            raise RunError("%s: the loader stacked the devices' layers as %s, not %s (exit %d)\n%s" %
                           (name, chains, layers, p.returncode, tail(p.stderr)))
        if TALLY in layers:
            check_output(name, output, p)
        found[name], first[name] = messages(log)
        processes[name] = p
    return found, processes, first


def tail(text, lines=12):
    """The end of an application's stderr, the loader's debug lines left out."""
    kept = [line for line in text.splitlines() if "LAYER:" not in line and line.strip()]
    return "\n".join(kept[-lines:])


def check_output(name, output, p):
    if not os.path.exists(output):
        raise RunError("%s: Tally's layer wrote no output (exit %d)\n%s" % (name, p.returncode, tail(p.stderr)))
    with open(output) as f:
        out = json.load(f)
    if not out["layer"]["counting_enabled"] or not out["frames"]:
        raise RunError("%s: Tally's layer did not count (%s, %d frames)" %
                       (name, out["layer"]["not_counting"], len(out["frames"])))


def defects(found):
    """Message keys that appear only where Tally's layer is loaded, with
    their counts per stack; empty when the layer adds no message."""
    alone = found["validation"]
    out = {}
    for name, counts in found.items():
        if name == "validation":
            continue
        for key, n in counts.items():
            if key not in alone:
                out.setdefault(key, {})[name] = n
    return out


def summary(found):
    """One line per stack: its message keys and counts."""
    return "; ".join("%s: %s" % (name, dict(sorted(c.items())) or "none") for name, c in found.items())

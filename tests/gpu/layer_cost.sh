#!/usr/bin/env bash
# What the Vulkan layer costs an application on the GPU, as its user sees it:
# the frame's wall time (submit to fence for `tallyd play`, present to present
# for an OpenGL application through Mesa's zink), plain and under the layer,
# side by side in one run, alternated so that drift hits every mode alike.
#
#   1. `tallyd play` on Sponza at LAYER_RESOLUTION (default 1920x1080), for each
#      renderer of LAYER_RENDERERS (default "forward deferred visbuffer"):
#      plain; under the layer counting every measured frame; under the layer
#      with no output file (it instruments, binds the plain pipelines and
#      counts nothing). PLAY_FRAMES frames (default 60), the first 10 dropped;
#      the median frame of each run, then the median of LAYER_REPEATS runs (3).
#   2. glmark2 (OpenGL through zink on the NVIDIA Vulkan driver) under a
#      carried Xvfb: the scenes of ZINK_SCENES (default "texture terrain") at
#      ZINK_SIZE (default 1920x1080) for ZINK_SECONDS each (default 5), in the
#      same three modes; glmark2's FPS gives the frame time.
#
# Needs tests/gpu/build.sh's build-gpu/ (tallyd and the layer), .gl/ (run.sh),
# .scenes/sponza (protocol.sh) for 1, and for 2 .xdebs-zink/zroot.tar.xz: the
# Debian packages glmark2-x11, glmark2-data, libgl1-mesa-dri, libglx-mesa0,
# libglapi-mesa, xvfb, x11-xkb-utils, xkb-data and the libraries they need
# that the machine lacks, unpacked into one tree and packed with tar and xz.
#   LAYER_COST_PLAY=0 skips 1, LAYER_COST_ZINK=0 skips 2.
#   LAYER_MODES (default "plain counting idle") may add: counting-timestamps
#   and counting-untimed (TALLY_LAYER_TIMING=timestamps, none: what the
#   layer's queries cost), counting-off (passes timed, nothing counted: the
#   second table compares each pass's GPU time with counting's),
#   counting-statistics (pipeline statistics in every frame, not only the
#   window's first: TALLY_LAYER_STATISTICS_FRAMES=all), and counting-before (the layer in
#   LAYER_DIR_BEFORE, another build, beside this one in the same run).
#   OUT=dir (default ./gpu-out): layer-cost.txt, layer-cost.json, layer-cost-logs.tar.gz
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
LAYER_RESOLUTION="${LAYER_RESOLUTION:-1920x1080}"
tally_gpu_script layer-cost LAYER_RESOLUTION || exit 2
layer_dir="${LAYER_DIR:-$PWD/build-gpu/layer}"
repeats="${LAYER_REPEATS:-3}"
logs="$out/layer-cost-logs"
mkdir -p "$logs"
rows="$logs/rows.jsonl"
: > "$rows"
layer_env=(VK_ADD_LAYER_PATH="$layer_dir" VK_INSTANCE_LAYERS=VK_LAYER_TALLY_counters
           VK_LOADER_LAYERS_ENABLE=VK_LAYER_TALLY_counters)

# mode_env MODE FRAMES SKIP LOG: the environment of one mode, as words.
modes="${LAYER_MODES:-plain counting idle}"
mode_env() {
  local counting="TALLY_LAYER_OUTPUT=$4.json TALLY_LAYER_SKIP_FRAMES=$3 TALLY_LAYER_FRAMES=$2"
  case "$1" in
    plain) ;;
    counting) echo "${layer_env[*]} $counting" ;;
    counting-timestamps) echo "${layer_env[*]} $counting TALLY_LAYER_TIMING=timestamps" ;;
    counting-untimed) echo "${layer_env[*]} $counting TALLY_LAYER_TIMING=none" ;;
    counting-off) echo "${layer_env[*]} $counting TALLY_LAYER_COUNTING=off" ;;
    counting-statistics) echo "${layer_env[*]} $counting TALLY_LAYER_STATISTICS_FRAMES=all" ;;
    counting-before) echo "${layer_env[*]/#VK_ADD_LAYER_PATH=*/VK_ADD_LAYER_PATH=$LAYER_DIR_BEFORE} $counting" ;;
    idle) echo "${layer_env[*]}" ;;
  esac
}

if [ "${LAYER_COST_PLAY:-1}" = 1 ]; then
  sponza="$(tally_sponza_path)"
  frames="${PLAY_FRAMES:-60}"
  for renderer in ${LAYER_RENDERERS:-forward deferred visbuffer}; do
    for rep in $(seq 1 "$repeats"); do
      for mode in $modes; do
        log="$logs/play-$renderer-$mode-$rep"
        # shellcheck disable=SC2046
        # tallyd play never presents: one submission is a frame.
        env TALLY_LAYER_FRAME_SUBMITS=1 $(mode_env "$mode" 100000 10 "$log") "$tallyd" play --renderer "$renderer" --scene "$sponza" \
          --resolution "$LAYER_RESOLUTION" --frames "$frames" > "$log.out" 2> "$log.err"
        rc=$?
        python3 - "$log.err" "$renderer" "$mode" "$rep" "$rc" >> "$rows" <<'EOF'
import json, re, statistics, sys
path, renderer, mode, rep, rc = sys.argv[1:]
ms = [float(m.group(1)) for m in re.finditer(r"tallyd play: frame \d+/\d+, \d+ passes, ([0-9.]+) ms", open(path).read())]
kept = ms[10:]
counted = None
passes = {}
try:
    frames = json.load(open(path[:-len(".err")] + ".json"))["frames"]
    counted = len(frames)
    for f in frames:
        for p in f["passes"]:
            if p["gpu_ms"] >= 0:
                passes.setdefault(p["name"], []).append(p["gpu_ms"])
except (OSError, ValueError, KeyError):
    pass
print(json.dumps({"app": "tallyd play " + renderer, "mode": mode, "repeat": int(rep), "exit": int(rc),
                  "frames": len(kept), "frames_counted_by_layer": counted,
                  "frame_ms": statistics.median(kept) if kept else None,
                  "pass_gpu_ms": {name: statistics.median(ms) for name, ms in passes.items()}}))
EOF
      done
    done
  done
fi

if [ "${LAYER_COST_ZINK:-1}" = 1 ]; then
  x=/tmp/tally-zink
  mkdir -p "$x"
  python3 -c "import sys, tarfile; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" .xdebs-zink/zroot.tar.xz "$x"
  xlibs="$x/usr/lib/x86_64-linux-gnu:$x/lib/x86_64-linux-gnu"
  [ -x /usr/bin/xkbcomp ] || cp "$x/usr/bin/xkbcomp" /usr/bin/xkbcomp
  [ -d /usr/share/X11/xkb ] || { mkdir -p /usr/share/X11 && cp -r "$x/usr/share/X11/xkb" /usr/share/X11/; }
  # Xvfb's own GLX loads Mesa's swrast_dri.so: from the unpacked tree.
  env LD_LIBRARY_PATH="$xlibs" LIBGL_DRIVERS_PATH="$x/usr/lib/x86_64-linux-gnu/dri" "$x/usr/bin/Xvfb" :78 -screen 0 1920x1080x24 -nolisten tcp > "$logs/xvfb.log" 2>&1 &
  xvfb=$!
  sleep 3
  # What the dynamic linker cannot find for Mesa's GL on this machine: the
  # first thing to read when glmark2 prints no FPS.
  for lib in "$x/usr/lib/x86_64-linux-gnu/dri/zink_dri.so" "$x/usr/lib/x86_64-linux-gnu/libGLX_mesa.so.0" "$x/usr/bin/glmark2"; do
    echo "== $lib"; LD_LIBRARY_PATH="$xlibs" ldd "$lib" | grep -E "not found|=> /(usr/)?lib" || true
  done > "$logs/zink-libraries.txt" 2>&1
  # Mesa 22.3's zink on the GPU (tests/gpu/diag/zink_probe.sh): without
  # LIBGL_ALWAYS_SOFTWARE, which makes zink take CPU devices only (lavapipe),
  # and without kopper, whose Vulkan swapchain on Xvfb crashes: frames go
  # to the X server by the software path, so zink never calls
  # vkQueuePresentKHR, and a frame is a submission.
  zink_env=(DISPLAY=:78 LIBGL_DEBUG=verbose XDG_RUNTIME_DIR=/tmp LD_LIBRARY_PATH="$xlibs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
            LIBGL_DRIVERS_PATH="$x/usr/lib/x86_64-linux-gnu/dri" __GLX_VENDOR_LIBRARY_NAME=mesa
            GALLIUM_DRIVER=zink MESA_LOADER_DRIVER_OVERRIDE=zink LIBGL_KOPPER_DISABLE=true
            TALLY_LAYER_FRAME_SUBMITS=1)
  size="${ZINK_SIZE:-1920x1080}"
  seconds="${ZINK_SECONDS:-5}"
  for scene in ${ZINK_SCENES:-texture terrain}; do
    for rep in $(seq 1 "$repeats"); do
      for mode in $modes; do
        log="$logs/glmark2-$scene-$mode-$rep"
        # shellcheck disable=SC2046
        env "${zink_env[@]}" $(mode_env "$mode" 100000 30 "$log") "$x/usr/bin/glmark2" \
          --data-path "$x/usr/share/glmark2" -s "$size" -b "$scene:duration=$seconds" > "$log.out" 2> "$log.err"
        rc=$?
        python3 - "$log.out" "$scene" "$mode" "$rep" "$rc" >> "$rows" <<'EOF'
import json, re, sys
path, scene, mode, rep, rc = sys.argv[1:]
text = open(path).read()
fps = [float(m.group(1)) for m in re.finditer(r"FPS: ([0-9.]+)", text)]
renderer = re.search(r"GL_RENDERER:\s*(.*)", text)
counted = None
try:
    counted = len(json.load(open(path[:-len(".out")] + ".json"))["frames"])
except (OSError, ValueError, KeyError):
    pass
print(json.dumps({"app": "glmark2 " + scene, "mode": mode, "repeat": int(rep), "exit": int(rc),
                  "frames_counted_by_layer": counted,
                  "renderer": renderer.group(1).strip() if renderer else None,
                  "frame_ms": 1000.0 / fps[0] if fps else None}))
EOF
      done
    done
  done
  kill "$xvfb" 2>/dev/null
fi

python3 - "$rows" "$out/layer-cost.json" > "$out/layer-cost.txt" <<'EOF'
import collections, json, statistics, sys
rows = [json.loads(line) for line in open(sys.argv[1]) if line.strip()]
json.dump(rows, open(sys.argv[2], "w"), indent=1)
by = collections.defaultdict(list)
for r in rows:
    if r["frame_ms"] is not None:
        by[(r["app"], r["mode"])].append(r["frame_ms"])
modes = [m for m in dict.fromkeys(r["mode"] for r in rows) if m != "plain"]
print("| application | plain frame ms | " + " | ".join("%s ms | x plain" % m for m in modes) + " |")
print("|---|---|" + "---|---|" * len(modes))
for app in dict.fromkeys(r["app"] for r in rows):
    med = {m: statistics.median(by[(app, m)]) if by[(app, m)] else None for m in ["plain"] + modes}
    def cell(m):
        return "n/a" if med[m] is None else "%.3f" % med[m]
    def ratio(m):
        return "n/a" if med[m] is None or not med["plain"] else "x%.3f" % (med[m] / med["plain"])
    print(f"| {app} | {cell('plain')} | " + " | ".join(f"{cell(m)} | {ratio(m)}" for m in modes) + " |")
# Each pass's GPU time (the layer's timestamps) in the modes that time passes.
timed = [m for m in modes if any(r.get("pass_gpu_ms") for r in rows if r["mode"] == m)]
if timed:
    print()
    print("| application | pass | " + " | ".join("%s GPU ms" % m for m in timed) + " |")
    print("|---|---|" + "---|" * len(timed))
    for app in dict.fromkeys(r["app"] for r in rows):
        names = dict.fromkeys(n for r in rows if r["app"] == app for n in r.get("pass_gpu_ms", {}))
        for name in names:
            cells = []
            for m in timed:
                ms = [r["pass_gpu_ms"][name] for r in rows
                      if r["app"] == app and r["mode"] == m and name in r.get("pass_gpu_ms", {})]
                cells.append("%.3f" % statistics.median(ms) if ms else "n/a")
            print(f"| {app} | {name} | " + " | ".join(cells) + " |")
failed = [r for r in rows if r["exit"] != 0 or r["frame_ms"] is None or
          (r["mode"].startswith("counting") and not r.get("frames_counted_by_layer"))]
for r in failed:
    print("failed:", json.dumps(r))
EOF
cat "$out/layer-cost.txt"
tar -C "$out" -czf "$out/layer-cost-logs.tar.gz" layer-cost-logs && rm -rf "$logs"

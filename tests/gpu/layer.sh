#!/usr/bin/env bash
# The Vulkan layer (VK_LAYER_TALLY_counters, docs/layer.md) on the GPU test
# machine. Build first with tests/gpu/build.sh; .gl/ as for run.sh, Sponza in
# .scenes/sponza, and for vkcube and the replay the Debian packages of Xvfb,
# vulkan-tools and gfxreconstruct (with the libraries they need that the
# machine lacks) in .xdebs/, unpacked into a folder of their own.
#
#   1. Every renderer on Sponza (LAYER_RESOLUTION, default 1920x1080), run by
#      `tallyd play` as a plain application under the layer, against the
#      built-in instrumentation (tests/layer/compare_builtin.py): every counted
#      line equal, and the layer's frame time against the plain frame's.
#   2. vkcube under Xvfb with and without the layer: its counts (texture reads
#      = fragment invocations, the statistic) and its frame time.
#   3. A GFXReconstruct capture of vkcube replayed with and without the layer:
#      the same counts as live, identical screenshots, the replay's time.
#
#   4. Without a window system: a GFXReconstruct capture of `tallyd play` on
#      Sponza replayed with and without the layer (counts against the live
#      run under the layer, replay time), and LAYER_VKCUBE_TRACE (a vkcube
#      trace recorded elsewhere) replayed headless.
#   LAYER_SPONZA=0 skips 1, LAYER_X=0 skips 2 and 3, LAYER_REPLAY=0 skips 4.
#   OUT=dir  (default ./gpu-out): layer-sponza.{json,txt}, vkcube.json.gz,
#            replay.json.gz, layer-summary.txt, layer-logs.tar.gz
set -uo pipefail
cd "$(dirname "$0")/../.."
. tests/gpu/env.sh
LAYER_RESOLUTION="${LAYER_RESOLUTION:-1920x1080}"
tally_gpu_script layer LAYER_RESOLUTION || exit 2
layer_dir="${LAYER_DIR:-$PWD/build-gpu/layer}"
logs="$out/layer-logs"
mkdir -p "$logs"
status=0
summary="$out/layer-summary.txt"
: > "$summary"

if [ "${LAYER_SPONZA:-1}" = 1 ]; then
  sponza="$(tally_sponza_path)"
  python3 tests/layer/compare_builtin.py --tallyd "$tallyd" --layer-dir "$layer_dir" \
    --scene "{\"gltf\": \"$sponza\"}" --resolution "$LAYER_RESOLUTION" --builtin-frames 10 --layer-frames 10 \
    --out "$out/layer-sponza.json" > "$out/layer-sponza.txt" 2>&1 || status=1
  cat "$out/layer-sponza.txt"
fi

if [ "${LAYER_X:-1}" = 1 ]; then
# Xvfb, vkcube and GFXReconstruct from .xdebs/, with their libraries, only
# for the programs that need them (python3 and tallyd keep the machine's).
x=/tmp/tally-x
mkdir -p "$x"
for f in .xdebs/*.deb; do dpkg -x "$f" "$x"; done
xlibs="$x/usr/lib/x86_64-linux-gnu:$x/lib/x86_64-linux-gnu"
# xrun [VAR=value...] PROGRAM ARGS: with the unpacked libraries first.
xrun() { env LD_LIBRARY_PATH="$xlibs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" "$@"; }
# Xvfb runs xkbcomp from /usr/bin and reads the keymaps from /usr/share/X11/xkb.
[ -x /usr/bin/xkbcomp ] || cp "$x/usr/bin/xkbcomp" /usr/bin/xkbcomp
[ -d /usr/share/X11/xkb ] || { mkdir -p /usr/share/X11 && cp -r "$x/usr/share/X11/xkb" /usr/share/X11/; }
xrun "$x/usr/bin/Xvfb" :77 -screen 0 1280x1024x24 -nolisten tcp > "$logs/xvfb.log" 2>&1 &
xvfb=$!
sleep 3
export DISPLAY=:77

layer_env=(VK_ADD_LAYER_PATH="$layer_dir" VK_INSTANCE_LAYERS=VK_LAYER_TALLY_counters
           VK_LOADER_LAYERS_ENABLE=VK_LAYER_TALLY_counters)
# Seconds for N frames of vkcube (immediate present), with the layer when $1 is "layer".
vkcube_seconds() {
  local mode="$1" frames="$2" start end
  start=$(date +%s%N)
  if [ "$mode" = layer ]; then
    xrun "${layer_env[@]}" TALLY_LAYER_OUTPUT="$logs/vkcube-$frames.json" TALLY_LAYER_SKIP_FRAMES=50 \
      TALLY_LAYER_FRAMES=20 "$x/usr/bin/vkcube" --c "$frames" --present_mode 0 > "$logs/vkcube-$mode-$frames.log" 2>&1
  else
    xrun "$x/usr/bin/vkcube" --c "$frames" --present_mode 0 > "$logs/vkcube-$mode-$frames.log" 2>&1
  fi
  local rc=$?
  end=$(date +%s%N)
  [ "$rc" -eq 0 ] || { echo "vkcube ($mode, $frames frames) exited $rc" >&2; tail -5 "$logs/vkcube-$mode-$frames.log" >&2; }
  echo "$(( (end - start) / 1000 ))"
}
if xrun "$x/usr/bin/vulkaninfo" --summary > "$logs/vulkaninfo.log" 2>&1; then :; fi
# Per-frame time from the difference of two runs (start-up cancels), alternated.
for rep in 1 2 3; do
  for mode in plain layer; do
    short=$(vkcube_seconds "$mode" 100)
    long=$(vkcube_seconds "$mode" 2100)
    echo "vkcube $mode rep $rep: 100 frames $short us, 2100 frames $long us, per frame $(( (long - short) / 2000 )) us" \
      | tee -a "$summary"
  done
done
[ -f "$logs/vkcube-2100.json" ] && gzip -c "$logs/vkcube-2100.json" > "$out/vkcube.json.gz"

# GFXReconstruct: capture vkcube, replay it with and without the layer.
trace="$logs/vkcube.gfxr"
xrun VK_ADD_LAYER_PATH="$x/usr/share/vulkan/explicit_layer.d" VK_INSTANCE_LAYERS=VK_LAYER_LUNARG_gfxreconstruct \
  GFXRECON_CAPTURE_FILE="$trace" GFXRECON_CAPTURE_FILE_TIMESTAMP=false \
  "$x/usr/bin/vkcube" --c 300 --present_mode 0 > "$logs/capture.log" 2>&1 || { echo "capture failed"; status=1; }
for mode in plain layer plain layer; do
  mkdir -p "$logs/shots-$mode"
  start=$(date +%s%N)
  if [ "$mode" = layer ]; then
    xrun "${layer_env[@]}" TALLY_LAYER_OUTPUT="$logs/replay.json" TALLY_LAYER_SKIP_FRAMES=50 TALLY_LAYER_FRAMES=20 \
      "$x/usr/bin/gfxrecon-replay" --screenshots 60-62 --screenshot-dir "$logs/shots-$mode" "$trace" \
      > "$logs/replay-$mode.log" 2>&1 || status=1
  else
    xrun "$x/usr/bin/gfxrecon-replay" --screenshots 60-62 --screenshot-dir "$logs/shots-$mode" "$trace" \
      > "$logs/replay-$mode.log" 2>&1 || status=1
  fi
  end=$(date +%s%N)
  echo "replay $mode: $(( (end - start) / 1000 )) us; $(grep -h 'Replay FPS' "$logs/replay-$mode.log")" | tee -a "$summary"
done
for f in "$logs"/shots-plain/*; do
  [ -f "$f" ] || continue
  if cmp -s "$f" "$logs/shots-layer/$(basename "$f")"; then echo "screenshot $(basename "$f"): identical"; else
    echo "screenshot $(basename "$f"): DIFFERS"; status=1; fi
done | tee -a "$summary"
[ -f "$logs/replay.json" ] && gzip -c "$logs/replay.json" > "$out/replay.json.gz"
kill "$xvfb" 2>/dev/null
fi

# 4. No window system needed: a GFXReconstruct capture of `tallyd play`
#    (deferred on Sponza, one submission a frame), replayed with and without
#    the layer: the replay counts what the live run under the layer counted,
#    and its time with the layer against without. And vkcube's trace (from
#    LAYER_VKCUBE_TRACE, recorded elsewhere) replayed headless where the
#    loader offers VK_EXT_headless_surface.
if [ "${LAYER_REPLAY:-1}" = 1 ]; then
  x=/tmp/tally-x
  mkdir -p "$x"
  [ -x "$x/usr/bin/gfxrecon-replay" ] || for f in .xdebs/*.deb; do dpkg -x "$f" "$x"; done
  xlibs="$x/usr/lib/x86_64-linux-gnu:$x/lib/x86_64-linux-gnu"
  gfx() { env LD_LIBRARY_PATH="$xlibs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" "$@"; }
  if [ -n "${LAYER_REPLAY_SCENE:-}" ]; then scene="$LAYER_REPLAY_SCENE"; else scene="{\"gltf\": \"$(tally_sponza_path)\"}"; fi
  play=("$tallyd" play --renderer "${LAYER_REPLAY_RENDERER:-deferred}" --scene "$scene"
        --resolution "$LAYER_RESOLUTION" --frames 40 --quiet)
  env VK_ADD_LAYER_PATH="$layer_dir" VK_INSTANCE_LAYERS=VK_LAYER_TALLY_counters TALLY_LAYER_OUTPUT="$logs/play-live.json" \
    TALLY_LAYER_SKIP_FRAMES=10 TALLY_LAYER_FRAMES=20 TALLY_LAYER_FRAME_SUBMITS=1 "${play[@]}" > "$logs/play-live.log" 2>&1 \
    || { echo "play under the layer failed"; tail -3 "$logs/play-live.log"; status=1; }
  ptrace="$logs/play.gfxr"
  gfx VK_ADD_LAYER_PATH="$x/usr/share/vulkan/explicit_layer.d" VK_INSTANCE_LAYERS=VK_LAYER_LUNARG_gfxreconstruct \
    GFXRECON_CAPTURE_FILE="$ptrace" GFXRECON_CAPTURE_FILE_TIMESTAMP=false "${play[@]}" > "$logs/play-capture.log" 2>&1 \
    || { echo "play under GFXReconstruct failed"; tail -3 "$logs/play-capture.log"; status=1; }
  echo "play trace: $(du -h "$ptrace" 2>/dev/null | cut -f1)" | tee -a "$summary"
  for mode in plain layer plain layer plain layer; do
    start=$(date +%s%N)
    if [ "$mode" = layer ]; then
      gfx VK_ADD_LAYER_PATH="$layer_dir" VK_INSTANCE_LAYERS=VK_LAYER_TALLY_counters TALLY_LAYER_OUTPUT="$logs/play-replay.json" \
        TALLY_LAYER_SKIP_FRAMES=10 TALLY_LAYER_FRAMES=20 TALLY_LAYER_FRAME_SUBMITS=1 \
        "$x/usr/bin/gfxrecon-replay" "$ptrace" > "$logs/play-replay-$mode.log" 2>&1 || status=1
    else
      gfx "$x/usr/bin/gfxrecon-replay" "$ptrace" > "$logs/play-replay-$mode.log" 2>&1 || status=1
    fi
    end=$(date +%s%N)
    echo "play replay $mode: $(( (end - start) / 1000 )) us" | tee -a "$summary"
  done
  for f in play-live play-replay; do [ -f "$logs/$f.json" ] && gzip -c "$logs/$f.json" > "$out/$f.json.gz"; done
  rm -f "$ptrace"
  if [ -n "${LAYER_VKCUBE_TRACE:-}" ]; then
    for mode in plain layer; do
      if [ "$mode" = layer ]; then
        gfx VK_ADD_LAYER_PATH="$layer_dir" VK_INSTANCE_LAYERS=VK_LAYER_TALLY_counters TALLY_LAYER_OUTPUT="$logs/vkcube-headless.json" \
          TALLY_LAYER_SKIP_FRAMES=2 TALLY_LAYER_FRAMES=4 "$x/usr/bin/gfxrecon-replay" --wsi headless "$LAYER_VKCUBE_TRACE" \
          > "$logs/vkcube-headless-$mode.log" 2>&1
      else
        gfx "$x/usr/bin/gfxrecon-replay" --wsi headless "$LAYER_VKCUBE_TRACE" > "$logs/vkcube-headless-$mode.log" 2>&1
      fi
      echo "vkcube trace replayed headless ($mode): exit $?; $(grep -h 'Replay FPS\|FATAL' "$logs/vkcube-headless-$mode.log" | head -1)" \
        | tee -a "$summary"
    done
    [ -f "$logs/vkcube-headless.json" ] && gzip -c "$logs/vkcube-headless.json" > "$out/vkcube-headless.json.gz"
  fi
fi

python3 tests/gpu/layer_summary.py "$out" | tee -a "$summary"
# Results name files relative to the repository, not the machine's folders.
for f in "$out"/*.json; do [ -f "$f" ] && sed -i "s|$PWD/||g" "$f"; done
for f in "$out"/*.json.gz; do [ -f "$f" ] && { zcat "$f" | sed "s|$PWD/||g" | gzip > "$f.tmp" && mv "$f.tmp" "$f"; }; done
rm -rf "$logs"/shots-* "${trace:-}"
tar -czf "$out/layer-logs.tar.gz" -C "$out" layer-logs && rm -rf "$logs"
exit "$status"

#!/bin/sh
# A stand-in for a Vulkan application under VK_LAYER_TALLY_counters: it reads
# the layer's environment (TALLY_LAYER_OUTPUT, _FRAMES, _SKIP_FRAMES, ...) and
# writes an output file of the layer's shape (docs/layer.md), or misbehaves on
# request. FAKE_APP_MODE (from the spec's env):
#   ok          write the output (temp file + rename) and exit 0 (the default)
#   linger      write the output, then keep running (FAKE_APP_IGNORE_TERM=1: ignore SIGTERM too)
#   segv        say something on stderr, then die of SIGSEGV before any output
#   exit1       say something on stderr, then exit 1 before any output
#   hang        never write anything
#   incomplete  write "complete": false with FAKE_APP_FRAMES_DONE frames (default 2), exit 0
#   badjson     write an output that is not JSON
#   silent      exit 0 without output (as when the layer did not load)
# FAKE_APP_RECORD=FILE: the environment and arguments it saw go there first,
# with RUN_UID (the user it runs as) and, under an X server, XVFB_PID (the Xvfb whose parent is ours) and
# XVFB_SOCKET (yes if the display's socket exists).
set -u
mode=${FAKE_APP_MODE:-ok}
frames=${TALLY_LAYER_FRAMES:-10}
skip=${TALLY_LAYER_SKIP_FRAMES:-0}
out=${TALLY_LAYER_OUTPUT:-}

if [ -n "${FAKE_APP_RECORD:-}" ]; then
  {
    env
    echo "ARGS=$*"
    echo "RUN_UID=$(id -u)"
    if [ -n "${DISPLAY:-}" ]; then
      n=${DISPLAY#:}
      n=${n%%.*}
      if [ -S "/tmp/.X11-unix/X$n" ]; then echo "XVFB_SOCKET=yes"; else echo "XVFB_SOCKET=no"; fi
      # The X server tallyd started is our sibling: an Xvfb with our parent.
      for stat in /proc/[0-9]*/stat; do
        line=$(cat "$stat" 2>/dev/null) || continue
        case "$line" in
          *"(Xvfb) "*)
            pid=${stat#/proc/}
            pid=${pid%/stat}
            [ "$(echo "$line" | awk '{print $4}')" = "$PPID" ] && echo "XVFB_PID=$pid" ;;
        esac
      done
    fi
  } > "$FAKE_APP_RECORD.tmp"
  mv "$FAKE_APP_RECORD.tmp" "$FAKE_APP_RECORD"
fi

# The layer's output with $1 frames; $2 is "complete".
write_output() {
  count=$1
  complete=$2
  {
    printf '{"complete": %s,\n' "$complete"
    printf ' "layer": {"name": "VK_LAYER_TALLY_counters", "version": "0.1.0", "counting": "%s", "descriptor_set": 7, "frame_delimiter": "present"},\n' "${TALLY_LAYER_COUNTING:-accumulate}"
    printf ' "application": {"name": "fakecube", "engine": "", "executable": "%s"},\n' "$0"
    printf ' "device": {"name": "Fake GPU", "vendorID": "0x10005", "deviceID": "0x0", "driverInfo": "fake 1.0", "apiVersion": "1.3.230", "timestamps": true, "pipeline_statistics": true},\n'
    printf ' "extent": [64, 48],\n'
    printf ' "resources": [{"name": "swapchain", "kind": "attachment", "format": "B8G8R8A8_UNORM", "element_bytes": 4, "width": 64, "height": 48, "samples": 1, "allocation_bytes": 12288, "usage": "color_attachment|transfer_src", "memory": ""},\n'
    printf '               {"name": "texture 0x1", "kind": "texture", "format": "R8G8B8A8_UNORM", "element_bytes": 4, "width": 16, "height": 16, "samples": 1, "allocation_bytes": 1024, "usage": "sampled", "memory": ""},\n'
    printf '               {"name": "buffer 0x2", "kind": "buffer", "format": "", "element_bytes": 0, "width": 0, "height": 0, "samples": 1, "allocation_bytes": 4096, "usage": "uniform_buffer", "memory": ""}],\n'
    printf ' "shaders": [{"name": "shader 0x10", "stage": "fragment", "instrumented": true, "sites": 2, "reason": ""},\n'
    printf '             {"name": "shader 0x11", "stage": "vertex", "instrumented": false, "sites": 0, "reason": "OpCapability Foo is not supported"}],\n'
    printf ' "notes": ["pipeline layout 0x20 uses every descriptor set the device allows (8): its pipelines run unchanged, uncounted"],\n'
    printf ' "frames": ['
    i=0
    while [ "$i" -lt "$count" ]; do
      [ "$i" -gt 0 ] && printf ','
      printf '\n  {"index": %d, "submissions": 1, "frame_ms": 1.5, "passes": [' $((skip + i))
      printf '{"name": "render pass 0", "gpu_ms": 0.5, "draws": 1, "dispatches": 0, "fragment_invocations": 3072, "fragment_invocations_statistic": 3072, "vertex_invocations": 36, "compute_invocations": 0, "compute_invocations_statistic": -1,'
      printf ' "resources": [{"name": "texture 0x1", "kind": "texture", "format": "R8G8B8A8_UNORM", "access": "read", "count": 3072, "bytes": 12288, "source": "counter"},'
      printf ' {"name": "buffer 0x2", "kind": "buffer", "format": "", "access": "read", "count": 36, "bytes": 2304, "source": "counter"},'
      printf ' {"name": "swapchain", "kind": "attachment", "format": "B8G8R8A8_UNORM", "access": "write", "count": 3072, "bytes": 12288, "source": "counter"}]},'
      printf ' {"name": "compute 1", "gpu_ms": 0.25, "draws": 0, "dispatches": 2, "fragment_invocations": 0, "fragment_invocations_statistic": -1, "vertex_invocations": 0, "compute_invocations": 128, "compute_invocations_statistic": 128,'
      printf ' "resources": [{"name": "buffer 0x2", "kind": "buffer", "format": "", "access": "write", "count": 128, "bytes": 512, "source": "counter"}]}]}'
      i=$((i + 1))
    done
    printf '\n ]}\n'
  } > "$out.tmp"
  mv "$out.tmp" "$out"
}

case "$mode" in
  ok) write_output "$frames" true ;;
  linger)
    [ "${FAKE_APP_IGNORE_TERM:-0}" = 1 ] && trap '' TERM
    write_output "$frames" true
    i=0
    while [ "$i" -lt 300 ]; do sleep 0.1; i=$((i + 1)); done ;;
  segv)
    echo "fake app: drawing frame 1" >&2
    echo "fake app: about to crash on request" >&2
    kill -SEGV $$ ;;
  exit1)
    echo "fake app: cannot open the window on request" >&2
    exit 1 ;;
  hang)
    echo "fake app: hanging on request" >&2
    while :; do sleep 1; done ;;
  incomplete) write_output "${FAKE_APP_FRAMES_DONE:-2}" false ;;
  badjson) echo "this is not JSON" > "$out" ;;
  silent) ;;
  *) echo "fake app: unknown FAKE_APP_MODE $mode" >&2; exit 2 ;;
esac
exit 0

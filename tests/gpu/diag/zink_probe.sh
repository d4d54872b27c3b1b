#!/usr/bin/env bash
# Which environment lets Mesa's zink (Mesa 22.3, from .xdebs-zink, see
# layer_cost.sh) drive glmark2 on the GPU machine's Vulkan driver under a
# carried Xvfb. Each variant runs glmark2's texture scene for one second and
# keeps its output and Mesa's messages in $OUT/zink-probe.txt. Used to find
# why layer_cost.sh's zink part gets no screen (docs/gpu.md).
set -uo pipefail
cd "$(dirname "$0")/../../.."
out="${OUT:-./gpu-out}"
mkdir -p "$out"
. tests/gpu/env.sh
tally_gpu_env || exit 2
x=/tmp/tally-zink
mkdir -p "$x"
python3 -c "import sys, tarfile; tarfile.open(sys.argv[1]).extractall(sys.argv[2])" .xdebs-zink/zroot.tar.xz "$x"
xlibs="$x/usr/lib/x86_64-linux-gnu:$x/lib/x86_64-linux-gnu"
[ -x /usr/bin/xkbcomp ] || cp "$x/usr/bin/xkbcomp" /usr/bin/xkbcomp
[ -d /usr/share/X11/xkb ] || { mkdir -p /usr/share/X11 && cp -r "$x/usr/share/X11/xkb" /usr/share/X11/; }
env LD_LIBRARY_PATH="$xlibs" LIBGL_DRIVERS_PATH="$x/usr/lib/x86_64-linux-gnu/dri" "$x/usr/bin/Xvfb" :79 -screen 0 1280x720x24 -nolisten tcp > "$out/xvfb-probe.log" 2>&1 &
xvfb=$!
sleep 3
base=(DISPLAY=:79 LIBGL_DEBUG=verbose MESA_DEBUG=1 XDG_RUNTIME_DIR=/tmp LD_LIBRARY_PATH="$xlibs${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
      LIBGL_DRIVERS_PATH="$x/usr/lib/x86_64-linux-gnu/dri" __GLX_VENDOR_LIBRARY_NAME=mesa GALLIUM_DRIVER=zink)
probe() {
  local name="$1"; shift
  echo "=== $name: $*"
  env "${base[@]}" "$@" timeout 60 "$x/usr/bin/glmark2" --data-path "$x/usr/share/glmark2" -s 640x360 \
    -b texture:duration=1 2>&1 | grep -vE "^\s*$" | head -40
  echo "=== $name: exit ${PIPESTATUS[0]}"
}
{
  probe software-cpu-only LIBGL_ALWAYS_SOFTWARE=1 MESA_LOADER_DRIVER_OVERRIDE=zink
  probe hardware-kopper MESA_LOADER_DRIVER_OVERRIDE=zink
  probe hardware-no-kopper MESA_LOADER_DRIVER_OVERRIDE=zink LIBGL_KOPPER_DISABLE=true
  probe hardware-kopper-dri2 MESA_LOADER_DRIVER_OVERRIDE=zink LIBGL_KOPPER_DRI2=1
  probe software-no-kopper LIBGL_ALWAYS_SOFTWARE=1 MESA_LOADER_DRIVER_OVERRIDE=zink LIBGL_KOPPER_DISABLE=true
} > "$out/zink-probe.txt" 2>&1
kill "$xvfb" 2>/dev/null
grep -E "^=== |GL_RENDERER|FPS" "$out/zink-probe.txt"

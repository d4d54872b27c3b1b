#!/usr/bin/env bash
# The Debian package, as a lab's GPU host gets Tally: CPack builds the .deb
# from this build tree; its control file must name a package for every
# shared library the binaries load (checked against readelf and dpkg -S, not
# against a list written here) and recommend Mesa's Vulkan drivers. It is
# unpacked with dpkg-deb -x into a temporary root, and from there, with the
# source and build trees hidden (a private mount namespace lays empty folders
# over them), tallyd serve runs with its defaults, tally captures a small
# spec through it, tally runs lists the run and GET / is the dashboard.
# Usage: package_test.sh BUILD_DIR SOURCE_DIR
set -uo pipefail
build=$(realpath "$1")
source=$(realpath "$2")
dir=$(mktemp -d /tmp/tally-package-XXXXXX)
trap 'rm -rf "$dir"' EXIT
fail=0
check() {  # check DESCRIPTION COMMAND...
  local what="$1"; shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what" >&2; fail=1; fi
}

cpack -G DEB --config "$build/CPackConfig.cmake" -B "$dir/pkg" > "$dir/cpack.log" 2>&1 \
  || { cat "$dir/cpack.log" >&2; exit 1; }
deb=$(ls "$dir"/pkg/tally_*_*.deb 2>/dev/null | head -1)
[ -f "$deb" ] || { echo "FAIL: no .deb in $dir/pkg" >&2; cat "$dir/cpack.log" >&2; exit 1; }
echo "package: $(basename "$deb"), $(du -h "$deb" | cut -f1)"

depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
# The package names in Depends, one a line ("libc6 (>= 2.34), ..." -> libc6).
names=$(tr ',' '\n' <<<"$depends" | awk '{ print $1 }')
depends_on() { grep -qxF "$1" <<<"$names"; }
check "Recommends mesa-vulkan-drivers" grep -qx "mesa-vulkan-drivers" <<<"$(dpkg-deb -f "$deb" Recommends)"
dpkg-deb -x "$deb" "$dir/root"
# Every library the binaries need comes from a package that Depends names.
for b in tallyd tally; do
  for lib in $(readelf -d "$dir/root/usr/bin/$b" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'); do
    path=$(ldconfig -p | awk -v l="$lib" '$1 == l && /x86-64/ { print $NF; exit }')
    owner=$(dpkg -S "$(realpath "$path")" 2>/dev/null | head -1 | cut -d: -f1)
    [ -z "$owner" ] && owner=$(dpkg -S "$path" 2>/dev/null | head -1 | cut -d: -f1)
    check "$b needs $lib, from ${owner:-?}, which Depends names" depends_on "${owner:-?}"
  done
done
check "the Vulkan loader is a dependency" depends_on libvulkan1
check "binaries are stripped" bash -c "! readelf -S '$dir/root/usr/bin/tallyd' | grep -q debug_info"
check "the unit runs /usr/bin/tallyd" \
  grep -qx "ExecStart=/usr/bin/tallyd serve --db /var/lib/tally/tally.db" "$dir/root/usr/lib/systemd/system/tallyd.service"
# The Vulkan layer: its manifest where the loader looks for explicit layers,
# naming the packaged library relative to itself (the loader resolves it from
# the manifest's folder: /usr/share/vulkan/explicit_layer.d/../../../lib/...).
manifest="$dir/root/usr/share/vulkan/explicit_layer.d/VkLayer_tally_counters.json"
check "packaged the layer's manifest" test -f "$manifest"
layer_rel=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["layer"]["library_path"])' "$manifest" 2>/dev/null)
layer_lib=$(realpath -m "$dir/root/usr/share/vulkan/explicit_layer.d/$layer_rel")
check "the manifest names the packaged library ($layer_rel)" \
  bash -c "[[ '$layer_rel' != /* ]] && [[ '$layer_lib' == '$dir/root/usr/lib/'* ]] && test -f '$layer_lib'"
check "the layer exports only the loader's entry points" bash -c \
  "[ \"\$(nm -D --defined-only '$layer_lib' | awk '\$2 == \"T\" { print \$3 }' | sort | tr '\n' ' ')\" = 'vkGetDeviceProcAddr vkGetInstanceProcAddr vkNegotiateLoaderLayerInterfaceVersion ' ]"
for f in usr/share/tally/shaders/forward.frag.glsl usr/share/tally/web/index.html usr/share/doc/tally/operating.md; do
  check "packaged $f" test -f "$dir/root/$f"
done

# From the unpacked root, with the trees out of reach. The steps run from a
# copy of this script's second half, outside the trees it hides.
cat > "$dir/run.sh" <<'RUN'
set -uo pipefail
root="$1"; dir="$2"; fail=0
check() { local what="$1"; shift; if "$@"; then echo "ok: $what"; else echo "FAIL: $what" >&2; fail=1; fi; }
cd "$dir"
echo '{"renderers":["forward","visbuffer-lean"],"scenes":["atrium"],"resolutions":[[48,27]],"frames":1,"cameras":[{"eye":[0,2,8],"target":[0,1,0]}]}' > spec.json
export XDG_DATA_HOME="$dir/xdg"
unset TALLY_DATA_DIR TALLY_SHADER_DIR
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
"$root/usr/bin/tallyd" serve --port "$port" > serve.out 2> serve.err &
pid=$!
for _ in $(seq 100); do curl -sf "http://127.0.0.1:$port/api/health" > /dev/null && break; sleep 0.1; done
url="http://127.0.0.1:$port"
check "tallyd serve answers" curl -sf "$url/api/health" -o health.json
check "its database is under \$XDG_DATA_HOME/tally" test -f "$dir/xdg/tally/tally.db"
check "GET / is the dashboard" bash -c "curl -sf '$url/' | grep -q '<title>Tally'"
check "tally capture" "$root/usr/bin/tally" --server "$url" capture --spec spec.json
"$root/usr/bin/tally" --server "$url" runs > runs.txt
check "tally runs lists both runs" bash -c "grep -c atrium runs.txt | grep -qx 2"
check "/metrics counts the capture" bash -c "curl -sf '$url/metrics' | grep -qx 'tally_jobs_finished_total{status=\"done\"} 1'"
kill "$pid"; wait "$pid"
check "tallyd serve stops cleanly on SIGTERM" grep -q 'msg=stopped' serve.err
[ "$fail" -eq 0 ] || { cat serve.out serve.err >&2; }
exit "$fail"
RUN
# The build tree first (it may lie inside the source tree), then the source.
hide=(unshare --mount bash -c "mount -t tmpfs tmpfs '$build' && mount -t tmpfs tmpfs '$source' && \
  test ! -e '$source/CMakeLists.txt' && test ! -e '$build/CMakeCache.txt' && bash '$dir/run.sh' '$dir/root' '$dir'")
if unshare --mount true 2>/dev/null; then
  echo "running from $dir/root with $source and $build hidden"
  "${hide[@]}" || fail=1
else
  echo "no mount namespace here (not root): running from $dir/root with the trees in place"
  bash "$dir/run.sh" "$dir/root" "$dir" || fail=1
fi
exit "$fail"

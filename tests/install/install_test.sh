#!/usr/bin/env bash
# The install tree: `cmake --install` into a prefix, then a copy of that tree
# elsewhere, run from another working directory:
#  - --version names the commit the build is from;
#  - tallyd capture finds its shaders beside the binary (bin/../share/tally):
#    with the copy's share/tally gone it fails naming where it looked (the
#    source tree is still there, so nothing falls back on it), and
#    TALLY_DATA_DIR then finds a data folder elsewhere;
#  - no path into the source tree is compiled into the binaries' data;
#  - tallyd serve with no options keeps its database under $XDG_DATA_HOME,
#    serves the installed dashboard at / and runs a capture sent by tally.
# Usage: install_test.sh BUILD_DIR SOURCE_DIR
set -uo pipefail
build=$(realpath "$1")
source=$(realpath "$2")
dir=$(mktemp -d)
pid=
cleanup() { [ -n "$pid" ] && kill "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$dir"; }
trap cleanup EXIT
fail=0
check() {  # check DESCRIPTION COMMAND...
  local what="$1"; shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what" >&2; fail=1; fi
}

cmake --install "$build" --prefix "$dir/prefix" > "$dir/install.log" 2>&1 \
  || { cat "$dir/install.log" >&2; exit 1; }
for f in bin/tallyd bin/tally share/tally/shaders/forward.frag.glsl share/tally/web/index.html \
         share/tally/migrations/0001_initial.sql share/tally/migrations/postgresql/0007_fleet.sql \
         lib/systemd/system/tallyd.service share/doc/tally/operating.md \
         share/vulkan/explicit_layer.d/VkLayer_tally_counters.json lib/libVkLayer_tally_counters.so; do
  check "installed $f" test -e "$dir/prefix/$f"
done
check "the unit runs the installed tallyd serve" \
  grep -q "^ExecStart=$dir/prefix/bin/tallyd serve --db /var/lib/tally/tally.db$" "$dir/prefix/lib/systemd/system/tallyd.service"
check "the fleet's API unit runs the api role on the shared store" \
  grep -q "^ExecStart=$dir/prefix/bin/tallyd serve --role api --store \${TALLY_STORE} " "$dir/prefix/lib/systemd/system/tallyd-api.service"
check "the fleet's worker unit runs the worker role named by the host" \
  grep -q "^ExecStart=$dir/prefix/bin/tallyd serve --role worker --store \${TALLY_STORE} --host-name %H$" \
  "$dir/prefix/lib/systemd/system/tallyd-worker.service"

# A copy of the install tree, away from the build and the source.
cp -a "$dir/prefix" "$dir/copy"
rm -rf "$dir/prefix"
tallyd="$dir/copy/bin/tallyd"
mkdir -p "$dir/work"
cd "$dir/work"

commit=$(git -C "$source" rev-parse --short=12 HEAD 2>/dev/null || echo unknown)
version=$("$tallyd" --version)
check "tallyd --version names the commit ($version)" grep -q "^tallyd [0-9.]* (commit $commit\(-dirty\)\?)$" <<<"$version"
check "tally --version names the commit" grep -q "commit $commit" <<<"$("$dir/copy/bin/tally" --version)"

# No source path in what the binaries read at run time (.rodata; the debug
# information may name source files, and is not read).
for b in tallyd tally; do
  objcopy -O binary --only-section=.rodata "$dir/copy/bin/$b" "$dir/$b.rodata"
  check "$b's data names no path into $source" bash -c "! grep -qa '$source/' '$dir/$b.rodata'"
done

spec='{"renderers":["forward"],"scenes":["atrium"],"resolutions":[[32,18]],"frames":1,"cameras":[{"eye":[0,2,8],"target":[0,1,0]}]}'
echo "$spec" > spec.json
unset TALLY_DATA_DIR TALLY_SHADER_DIR
check "the copied tallyd captures from $PWD" "$tallyd" capture --spec spec.json --out result.json --quiet
check "the result has a run" python3 -c 'import json,sys; r=json.load(open("result.json")); sys.exit(0 if r["runs"] else 1)'

# An application under the copied tree's layer (its manifest names the
# library relative to itself, so the copy works where the prefix is gone).
if command -v vkcube > /dev/null && command -v Xvfb > /dev/null; then
  echo '{"application":{"command":["vkcube","--c","8"],"frames":2,"skip_frames":2,"display":"xvfb"}}' > app.json
  check "the copied tallyd captures vkcube under the copied layer" \
    "$tallyd" capture --spec app.json --out app-result.json --quiet
  check "the application's run counts texture reads" python3 -c 'import json,sys
r = json.load(open("app-result.json"))["runs"][0]
sys.exit(0 if r["renderer"] == "app:vkcube" and any(x["kind"] == "texture" and x["count"] > 0
         for s in r["samples"] for p in s["passes"] for x in p["resources"]) else 1)'
fi

mv "$dir/copy/share/tally" "$dir/data"
if "$tallyd" capture --spec spec.json --out gone.json --quiet 2> gone.log; then
  echo "FAIL: a capture ran with the copy's data folder gone" >&2; fail=1
else
  check "without share/tally the capture names where it looked" grep -q "no Tally data folder.*$dir/copy/share/tally" gone.log
fi
check "TALLY_DATA_DIR finds a data folder elsewhere" \
  env TALLY_DATA_DIR="$dir/data" "$tallyd" capture --spec spec.json --out env.json --quiet
mv "$dir/data" "$dir/copy/share/tally"

# tallyd serve with no options but a port: database in $XDG_DATA_HOME/tally,
# the installed dashboard at /, loopback only.
export XDG_DATA_HOME="$dir/xdg"
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
"$tallyd" serve --port "$port" > serve.log 2>&1 &
pid=$!
for _ in $(seq 100); do
  curl -sf "http://127.0.0.1:$port/api/health" > /dev/null && break
  sleep 0.1
done
check "serve listens on loopback" grep -q "serving http://127.0.0.1:$port/" serve.log
check "serve keeps its database in \$XDG_DATA_HOME/tally" test -f "$dir/xdg/tally/tally.db"
check "GET / is the installed dashboard" bash -c "curl -sf http://127.0.0.1:$port/ | grep -q '<title>Tally'"
client=("$dir/copy/bin/tally" --server "http://127.0.0.1:$port")
check "tally capture through the copied daemon" "${client[@]}" capture --spec spec.json
check "tally runs lists the run" bash -c "'${client[0]}' --server http://127.0.0.1:$port runs | grep -q atrium"
check "/api/health names the commit" bash -c "curl -sf http://127.0.0.1:$port/api/health | grep -q '\"commit\":\"$commit'"
[ "$fail" -eq 0 ] || { echo "--- serve.log" >&2; cat serve.log >&2; }
exit "$fail"

#!/usr/bin/env bash
# The main job: installs what is missing, builds, starts `tallyd serve` (or
# uses the one already on the port), and submits a capture comparing deferred
# shading, the fat and lean visibility buffers and forward rendering on the
# default scene (atrium, 10 auto cameras) at a small resolution, on whatever
# Vulkan device is present (lavapipe without a GPU). Prints the comparison per
# pass and per resource (against deferred) and the dashboard's address. The
# daemon keeps running afterwards so that the dashboard can be browsed.
#
#   TALLY_PORT=8377   the port to serve on (loopback only)
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j"$(nproc)" --target tallyd tally

port="${TALLY_PORT:-8377}"
server="http://127.0.0.1:$port"
tally() { build/client/tally --server "$server" "$@"; }
mkdir -p build/demo

if tally --timeout 2 status >/dev/null 2>&1; then
  echo "using the tallyd already serving $server"
else
  build/server/tallyd serve --db build/demo/tally.db --web web --port "$port" >build/demo/tallyd.log 2>&1 &
  echo $! >build/demo/tallyd.pid
  for _ in $(seq 100); do
    tally --timeout 2 status >/dev/null 2>&1 && break
    if ! kill -0 "$(cat build/demo/tallyd.pid)" 2>/dev/null; then
      echo "tallyd serve did not start:" >&2
      cat build/demo/tallyd.log >&2
      exit 1
    fi
    sleep 0.2
  done
  echo "tallyd serving $server (pid $(cat build/demo/tallyd.pid), database build/demo/tally.db, log build/demo/tallyd.log)"
fi

# The capture: progress on stderr, then "capture N done ...".
done_line=$(tally capture --spec scripts/demo.json --interval 0.5 | tail -n 1)
echo "$done_line"
capture=$(sed -n 's/^capture \([0-9]*\) done.*/\1/p' <<<"$done_line")
# Its runs in the order of the spec (ids ascending): deferred first, the reference of the ratios.
runs=$(tally runs --capture "$capture" --json | grep -o '"id": *[0-9]*' | grep -o '[0-9]*$' | sort -n | tr '\n' ' ')
echo
tally runs --capture "$capture"
echo
# shellcheck disable=SC2086  # one argument per run id
tally compare $runs
echo
echo "dashboard:  $server/#/compare?runs=$(tr ' ' ',' <<<"${runs% }")"
echo "runs:       $server/#/runs?capture=$capture"
if [[ -f build/demo/tallyd.pid ]]; then
  echo "stop the daemon with: kill $(cat build/demo/tallyd.pid)"
fi

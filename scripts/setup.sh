#!/usr/bin/env bash
# Installs the Debian packages Tally builds and runs with, if any are missing.
# Idempotent: does nothing (and needs no network) when all are present.
# Also vendors the dashboard's npm packages (below).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libvulkan-dev mesa-vulkan-drivers vulkan-tools
  glslang-dev glslang-tools spirv-tools spirv-headers
  libglm-dev libcpp-httplib-dev nlohmann-json3-dev libsqlite3-dev libstb-dev
  libtinygltf-dev libcli11-dev libgtest-dev libmeshoptimizer-dev
  # Boost.Math (headers only): the normal distribution's quantiles and tails
  # for the significance of time differences (server/analysis/significance.cpp)
  # and Student's t quantiles for the crossover fits (crossover.cpp).
  libboost-math-dev
  chromium
  # The install and package tests (curl, dpkg-shlibdeps for CPack's Depends)
  # and the /metrics test's parser (Debian's python3, /usr/bin/python3).
  curl dpkg-dev python3-prometheus-client
  # The Vulkan layer: application captures (docs/layer.md) under a virtual X
  # server ("display": "xvfb"; xvfb-run needs xauth), vkcube (vulkan-tools,
  # above), GFXReconstruct's capture layer and replayer (replays, the layer's
  # tests and tallyd play's trace: tests/capture/play_trace.py).
  xvfb xauth gfxreconstruct
  # OpenGL applications through Mesa's zink under the layer (layer.zink).
  glmark2-x11 libgl1-mesa-dri
  # The fleet store and its tests (PostgreSQL server and client, libpq).
  postgresql libpq-dev
  # The sanitizer tree and the fuzz harnesses (tests/fuzz/, TALLY_FUZZ=ON):
  # clang, and its runtimes (ASan, UBSan and libFuzzer's libclang_rt.fuzzer).
  clang libclang-rt-14-dev
  # Builds reuse the objects of earlier builds on the same machine (test.sh).
  ccache
  # The suite on a busy machine: TALLY_TEST_LOAD=N scripts/test.sh runs the
  # tests beside N CPU-bound stress-ng workers.
  stress-ng
)
# The dashboard's npm packages need node and npm; take Debian's only when there are none.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then packages+=(nodejs npm); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The web dashboard's chart library and the browser tests' Playwright, from
# npm as tests/web/package-lock.json pins them (npm ci only when the lock file
# changed); Chart.js is copied into web/vendor/ (git-ignored): no CDN.
cd "$(dirname "$0")/.."
if [ ! -f tests/web/node_modules/.package-lock.json ] ||
   [ tests/web/package-lock.json -nt tests/web/node_modules/.package-lock.json ]; then
  echo "setup: npm ci in tests/web"
  (cd tests/web && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
fi
chart=tests/web/node_modules/chart.js/dist/chart.umd.min.js
if ! cmp -s "$chart" web/vendor/chart.umd.min.js; then
  mkdir -p web/vendor
  cp "$chart" web/vendor/chart.umd.min.js
fi

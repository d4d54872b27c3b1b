#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs a capture comparing
# deferred shading, the fat and lean visibility buffers and forward rendering
# on the default scene (atrium, 10 auto cameras) at a small resolution, on
# whatever Vulkan device is present (lavapipe without a GPU). Prints the
# per-pass, per-resource summary with totals and ratios against deferred.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j"$(nproc)" --target tallyd tally

mkdir -p build/demo
build/server/tallyd capture --spec scripts/demo.json --out build/demo/result.json --summary
echo
echo "result: build/demo/result.json (schema: docs/result-schema.md)"
echo "screenshots: build/demo/result-screenshots/"
echo "dashboard: not built yet; the service and dashboard issues add it (tallyd serve)."

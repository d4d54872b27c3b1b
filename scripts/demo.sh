#!/usr/bin/env bash
# The main job: installs what is missing, builds, and instruments the
# project's own shaders in every counting mode, printing their site tables.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build -j"$(nproc)" --target tallyd tally

for mode in exact subgroup sampled:16; do
  echo "=== mode $mode ==="
  build/server/tallyd demo --shaders shaders --mode "$mode"
done

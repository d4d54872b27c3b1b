#!/usr/bin/env bash
# Captures the four Khronos glTF test models in ../shared/scenes/khronos on
# every renderer, one camera each placed as the model's reference screenshot,
# and puts each renderer's image beside the reference in OUT (default
# build/khronos): OUT/<model>/<renderer>.png, OUT/<model>/reference.png.
# docs/scenes.md says what matches. Usage: tests/scenes/khronos/run.sh [OUT]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
# KHRONOS_DIR: the models elsewhere (the GPU machine has a copy in .scenes/khronos).
models=$(cd "${KHRONOS_DIR:-$root/../shared/scenes/khronos}" 2>/dev/null && pwd) || { echo "no Khronos models (../shared/scenes/khronos or KHRONOS_DIR)" >&2; exit 1; }
out=${1:-$root/build/khronos}
tallyd=${TALLYD:-$root/build/server/tallyd}
mkdir -p "$out"
for spec in "$here"/*.json; do
  model=$(basename "$spec" .json)
  mkdir -p "$out/$model"
  sed "s#\"gltf\": \"#\"gltf\": \"$models/#" "$spec" > "$out/$model/spec.json"
  "$tallyd" capture --spec "$out/$model/spec.json" --out "$out/$model/result.json" --summary > "$out/$model/summary.txt"
  for f in "$out/$model"/result.json-screenshots/*.png "$out/$model"/result-screenshots/*.png; do
    [ -e "$f" ] || continue
    renderer=$(basename "$f" | cut -d_ -f1)
    cp "$f" "$out/$model/$renderer.png"
  done
  ref=$(ls "$models/$model/screenshot/"screenshot.* 2>/dev/null | head -n 1)
  [ -n "$ref" ] || continue
  if command -v convert >/dev/null && [ "${ref##*.}" != png ]; then convert "$ref" "$out/$model/reference.png"; else cp "$ref" "$out/$model/reference.png"; fi
  echo "$model: $(ls "$out/$model" | tr '\n' ' ')"
done

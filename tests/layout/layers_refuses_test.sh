#!/usr/bin/env bash
# layers.py can fail: an upward include (gpu/ including capture/) and a part
# missing from the table are each refused, naming the file and the rule.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/server/gpu" "$tmp/server/capture" "$tmp/server/extra"
printf '#include "spirv/module.hpp"\n#include "capture/runner.hpp"\n' > "$tmp/server/gpu/context.cpp"
printf '#include "sweeps/sweep.hpp"\n' > "$tmp/server/capture/runner.cpp"
if out="$(python3 "$here/layers.py" "$tmp/server")"; then
  echo "layers.py passed a tree with an upward include" >&2
  exit 1
fi
grep -qx 'server/gpu/context.cpp:2: server/gpu may not include capture/ (allowed: spirv)' <<<"$out" \
  || { echo "no error for gpu -> capture in: $out" >&2; exit 1; }
grep -q '^server/extra/: a part not in the layer table' <<<"$out" \
  || { echo "no error for the unknown part in: $out" >&2; exit 1; }
if grep -q 'runner.cpp' <<<"$out"; then
  echo "capture -> sweeps is allowed, but was refused: $out" >&2
  exit 1
fi
echo "layers.py refuses what it should"

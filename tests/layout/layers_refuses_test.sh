#!/usr/bin/env bash
# layers.py can fail: an upward include (gpu/ including capture/), a part
# missing from the table, and an architecture page that disagrees with the
# table are each refused, naming the file and the rule.
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
# The architecture page and the script must agree: a row that says gpu/ may
# use scenes/ is refused.
mkdir -p "$tmp/docs"
printf '| part | library | owns | may use |\n|---|---|---|---|\n| `gpu/` | `tally_gpu` | Vulkan | scenes |\n' > "$tmp/docs/architecture.md"
rm -rf "$tmp/server/extra"
printf '#include "spirv/module.hpp"\n' > "$tmp/server/gpu/context.cpp"
if out="$(python3 "$here/layers.py" "$tmp/server")"; then
  echo "layers.py passed a page that disagrees with it" >&2
  exit 1
fi
grep -q 'architecture.md: gpu/ may use scenes there, but spirv in tests/layout/layers.py' <<<"$out" \
  || { echo "no error for the page's gpu row in: $out" >&2; exit 1; }
echo "layers.py refuses what it should"

#!/usr/bin/env bash
# Instruments a folder of someone else's GLSL shaders (e.g. glslang's Test/,
# from a checkout of https://github.com/KhronosGroup/glslang) with footprint
# on, checks every instrumented module with spirv-val, and reports what was
# instrumented, what glslang or Tally refused, what spirv-val refused, and how
# many access sites were marked. Not part of the suite: it needs that
# checkout, which the build does not download.
#
#   tests/spirv/external_corpus.sh DIR [TALLYD]     TALLYD defaults to build/server/tallyd
#   PATTERN='spv.*' chooses the files instead (default: spv.* and vulkan.*; only .frag/.vert/.comp)
#   MODE=accumulate:subgroup  the counting mode (default: tallyd instrument's)
set -uo pipefail
dir="${1:?usage: external_corpus.sh DIR [TALLYD]}"
tallyd="${2:-build/server/tallyd}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
ok=0 glslangRefused=0 tallyRefused=0 invalid=0 sites=0 marked=0
mode=()
[ -n "${MODE:-}" ] && mode=(--mode "$MODE")
files=("$dir"/spv.* "$dir"/vulkan.*)
[ -n "${PATTERN:-}" ] && files=("$dir"/$PATTERN)
for f in "${files[@]}"; do
  case "$f" in *.frag|*.vert|*.comp) ;; *) continue ;; esac
  glslangValidator -V --target-env vulkan1.2 "$f" -o "$work/in.spv" >/dev/null 2>&1 || { glslangRefused=$((glslangRefused + 1)); continue; }
  if "$tallyd" instrument "${mode[@]}" --footprint 64 -o "$work/out.spv" "$work/in.spv" > "$work/sites.json" 2> "$work/err.txt"; then
    ok=$((ok + 1))
    if ! spirv-val --target-env vulkan1.2 "$work/out.spv" > "$work/val.txt" 2>&1; then
      invalid=$((invalid + 1))
      echo "spirv-val refused $(basename "$f"): $(head -c 300 "$work/val.txt")"
    fi
    read -r n m < <(python3 -c "
import json, sys
j = json.load(open('$work/sites.json'))
s = [x for x in j['sites'] if x['kind'] != 'invocation']
print(len(s), sum(1 for x in s if x.get('footprint')))
for n in j['notes']:
    if n.startswith('footprint'): print(n, file=sys.stderr)
" 2>> "$work/notes.txt")
    sites=$((sites + n)); marked=$((marked + m))
  else
    tallyRefused=$((tallyRefused + 1))
    echo "refused $(basename "$f"): $(head -c 300 "$work/err.txt")"
  fi
done
echo "instrumented with footprint $ok (spirv-val refused $invalid); glslang refused $glslangRefused; Tally refused $tallyRefused"
echo "access sites $sites, marked $marked"
sort "$work/notes.txt" 2>/dev/null | uniq -c | sort -rn
[ "$invalid" = 0 ]

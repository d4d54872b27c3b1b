#!/usr/bin/env bash
# Instruments a folder of someone else's GLSL shaders (e.g. glslang's Test/,
# from a checkout of https://github.com/KhronosGroup/glslang) with footprint
# on, and reports what was instrumented, what glslang or Tally refused, and
# how many access sites were marked. Not part of the suite: it needs that
# checkout, which the build does not download.
#
#   tests/spirv/external_corpus.sh DIR [TALLYD]     TALLYD defaults to build/server/tallyd
#   PATTERN='spv.*' narrows the files (default: spv.* and vulkan.* .frag/.vert/.comp)
set -uo pipefail
dir="${1:?usage: external_corpus.sh DIR [TALLYD]}"
tallyd="${2:-build/server/tallyd}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
ok=0 glslangRefused=0 tallyRefused=0 sites=0 marked=0
for f in "$dir"/${PATTERN:-spv.*} "$dir"/vulkan.*; do
  case "$f" in *.frag|*.vert|*.comp) ;; *) continue ;; esac
  glslangValidator -V --target-env vulkan1.2 "$f" -o "$work/in.spv" >/dev/null 2>&1 || { glslangRefused=$((glslangRefused + 1)); continue; }
  if "$tallyd" instrument --footprint 64 -o "$work/out.spv" "$work/in.spv" > "$work/sites.json" 2> "$work/err.txt"; then
    ok=$((ok + 1))
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
echo "instrumented with footprint $ok; glslang refused $glslangRefused; Tally refused $tallyRefused"
echo "access sites $sites, marked $marked"
sort "$work/notes.txt" 2>/dev/null | uniq -c | sort -rn

#!/usr/bin/env bash
# Gathers the fuzz harnesses' seed corpora into OUT/<harness>/ (in the build
# tree: generated, never committed). Seeds are the tests' own inputs and,
# where present, outside ones: glslang's Test/ shaders (from a checkout named
# by GLSLANG_TEST or found at ../shared/glslang/Test) and the Khronos glTF
# models in ../shared/scenes. Usage: make_corpus.sh OUT
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:?usage: make_corpus.sh OUT}
mkdir -p "$out"/{spirv,gltf,spec,http,ingest}
shared=${TALLY_SHARED:-$(cd .. && pwd)/shared}

# --- spirv: the repo's GLSL (the passes and the SPIR-V corpus) compiled by
# glslangValidator; every stage from the file name (<name>.<stage>.glsl).
compile() {  # compile SOURCE STAGE NAME
  glslangValidator -V --target-env vulkan1.1 -S "$2" -Ishaders -o "$out/spirv/$3.spv" "$1" >/dev/null 2>&1 ||
    rm -f "$out/spirv/$3.spv"
}
for f in shaders/*.glsl tests/spirv/corpus/*.glsl; do
  base=$(basename "$f" .glsl)
  compile "$f" "${base##*.}" "$(basename "$(dirname "$f")")-$base"
done
# glslang's own test shaders: those that compile for Vulkan (many are for
# OpenGL, or are meant to fail), at most 20 KB of source each.
glslang_test=${GLSLANG_TEST:-$shared/glslang/Test}
if [ -d "$glslang_test" ]; then
  for f in "$glslang_test"/*.{vert,frag,comp,geom,tesc,tese}; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 20480 ] || continue
    name=$(basename "$f")
    compile "$f" "${name##*.}" "glslang-$name"
  done
else
  echo "make_corpus.sh: no glslang Test/ at $glslang_test; its shaders are left out" >&2
fi

# --- gltf: the Khronos models, each made self-contained (buffers and small
# images as data: URIs; larger images replaced by a 1x1 PNG, as the fuzzer
# gains nothing from decoding megabytes of texels), Sponza's JSON alone.
python3 - "$shared/scenes" "$out/gltf" <<'PY'
import base64, json, pathlib, sys, zlib, struct
scenes, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
def png1x1():
    def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 1, 1, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00\xff\x00\x00\xff")) + chunk(b"IEND", b""))
tiny = "data:image/png;base64," + base64.b64encode(png1x1()).decode()
for path in sorted(scenes.glob("*/*/glTF/*.gltf")) if scenes.is_dir() else []:
    doc = json.loads(path.read_text())
    if "sponza" in str(path).lower():
        (out / ("sponza-" + path.name)).write_text(json.dumps(doc))
        continue
    for b in doc.get("buffers", []):
        if "uri" in b and not b["uri"].startswith("data:"):
            b["uri"] = "data:application/octet-stream;base64," + base64.b64encode((path.parent / b["uri"]).read_bytes()).decode()
    for i in doc.get("images", []):
        if "uri" in i and not i["uri"].startswith("data:"):
            f = path.parent / i["uri"]
            i["uri"] = tiny if not f.exists() or f.stat().st_size > 65536 else \
                "data:image/png;base64," + base64.b64encode(f.read_bytes()).decode()
    (out / path.name).write_text(json.dumps(doc))
    # The same as a .glb: JSON chunk, no binary chunk (buffers stay data: URIs).
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    glb = b"glTF" + struct.pack("<II", 2, 12 + 8 + len(js)) + struct.pack("<I", len(js)) + b"JSON" + js
    (out / (path.stem + ".glb")).write_bytes(glb)
for path in sorted(scenes.glob("sponza/**/*.gltf")) if scenes.is_dir() else []:
    (out / ("sponza-" + path.name)).write_bytes(path.read_bytes())
PY


# --- spec: every capture, sweep and heatmap spec the tests and docs use.
i=0
for f in scripts/demo.json tests/gpu/*.json tests/gpu/*/*.json tests/scenes/khronos/*.json \
         docs/data/*spec*.json docs/data/*/spec.json docs/data/*/*/spec.json; do
  [ -f "$f" ] || continue
  cp "$f" "$out/spec/$(printf %03d $i)-$(basename "$f")"
  i=$((i + 1))
done

# --- http: the requests in tests/fuzz/seeds/http (written for the gate).
cp tests/fuzz/seeds/http/* "$out/http/"

# --- ingest: real capture results from docs/data (gzipped), up to 256 KB each.
for f in docs/data/*/*.json.gz docs/data/*.json.gz; do
  [ -f "$f" ] || continue
  name=$(basename "$f" .gz)
  zcat "$f" >"$out/ingest/$name"
  [ "$(stat -c %s "$out/ingest/$name")" -le 262144 ] || rm "$out/ingest/$name"
done
for h in spirv gltf spec http ingest; do
  echo "make_corpus.sh: $h: $(ls "$out/$h" | wc -l) seeds, $(du -sk "$out/$h" | cut -f1) KiB"
done

#!/usr/bin/env bash
# tallyd capture and user scenes: a relative glTF path resolves against the
# spec file's folder (run from another working directory); with the spec on
# standard input a relative path is refused, naming the field; and a
# renderer that cannot draw a scene (the visibility buffers' 512 draws) is
# refused before any frame is rendered, naming the renderer and the limit.
# Usage: scene_paths_test.sh TALLYD
set -uo pipefail
tallyd=$(realpath "$1")
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
mkdir -p "$dir/specs/models" "$dir/elsewhere"
python3 - "$dir/specs/models" <<'PY'
import base64, json, struct, sys
d = sys.argv[1]
def scene(quads):
    b = b""
    views, accessors, meshes, nodes = [], [], [], []
    for q in range(quads):
        x = (q % 32) * 1.5; y = (q // 32) * 1.5
        pos = struct.pack("<12f", x, y, 0, x + 1, y, 0, x + 1, y + 1, 0, x, y + 1, 0)
        idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3) + b"\0\0"
        views += [{"buffer": 0, "byteOffset": len(b), "byteLength": 48}, {"buffer": 0, "byteOffset": len(b) + 48, "byteLength": 12}]
        accessors += [{"bufferView": 2 * q, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [x, y, 0], "max": [x + 1, y + 1, 0]},
                      {"bufferView": 2 * q + 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]
        b += pos + idx
        meshes.append({"primitives": [{"attributes": {"POSITION": 2 * q}, "indices": 2 * q + 1}]})
        nodes.append({"mesh": q})
    return {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(quads))}], "nodes": nodes,
            "meshes": meshes, "accessors": accessors, "bufferViews": views,
            "buffers": [{"byteLength": len(b), "uri": "data:application/octet-stream;base64," + base64.b64encode(b).decode()}]}
json.dump(scene(1), open(f"{d}/one.gltf", "w"))
json.dump(scene(513), open(f"{d}/many.gltf", "w"))
PY
fail=0
spec='{"renderers":["forward"],"scenes":[{"gltf":"models/one.gltf"}],"resolutions":[[32,18]],"frames":1,
       "cameras":[{"eye":[0.5,0.5,2],"target":[0.5,0.5,0]}]}'
echo "$spec" > "$dir/specs/relative.json"
if (cd "$dir/elsewhere" && "$tallyd" capture --spec ../specs/relative.json --out out.json > log 2>&1); then
  echo "ok relative path resolved against the spec's folder"
else
  echo "FAIL relative path: $(cat "$dir/elsewhere/log")"; fail=1
fi
msg=$(cd "$dir/specs" && echo "$spec" | "$tallyd" capture --spec - --out "$dir/stdin.json" 2>&1 >/dev/null)
if [ $? -eq 1 ] && [[ "$msg" == *'scenes[0].gltf: the relative path "models/one.gltf" needs a spec file'* ]]; then
  echo "ok relative path from stdin refused: $msg"
else
  echo "FAIL relative path from stdin: $msg"; fail=1
fi
echo '{"renderers":["forward","deferred","visbuffer"],"scenes":[{"gltf":"models/many.gltf"}],"resolutions":[[32,18]],"frames":1,
       "cameras":[{"eye":[24,6,30],"target":[24,6,0]}]}' > "$dir/specs/many.json"
out=$("$tallyd" capture --spec "$dir/specs/many.json" --out "$dir/many.out.json" 2>&1)
rc=$?
if [ $rc -eq 1 ] && [[ "$out" == *"visbuffer: the scene has 513 draws; the visibility id holds at most 512"* ]] &&
   [[ "$out" != *"[1/"* ]] && [ ! -e "$dir/many.out.json" ]; then
  echo "ok refused before rendering: $out"
else
  echo "FAIL 513 draws (exit $rc): $out"; fail=1
fi
exit $fail

#!/usr/bin/env bash
# `tallyd capture` on broken glTF files (the library's table is
# gltf_broken_test.cpp): each exits 1, within a time limit and a memory cap,
# with a message naming the file and the element, and writes no result.
# Usage: broken_capture_test.sh TALLYD
set -uo pipefail
tallyd=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
python3 - "$dir" <<'PY'
import base64, json, struct, sys
d = sys.argv[1]
def quad(positions, extra=None):
    b = struct.pack("<12f", *positions) + struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
           "buffers": [{"byteLength": len(b), "uri": "data:application/octet-stream;base64," + base64.b64encode(b).decode()}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
    if extra: extra(doc)
    return doc
ok = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]
nan = ok[:]; nan[4] = float("nan")
def chain(doc):  # each node lists the next twice: 2^40 instances
    doc["nodes"] = [{"children": [i + 1, i + 1]} for i in range(40)] + [{"mesh": 0}]
def stride(doc): doc["bufferViews"][0]["byteStride"] = 8
def required(doc): doc["extensionsUsed"] = doc["extensionsRequired"] = ["KHR_materials_pbrSpecularGlossiness"]
for name, doc in {"nan": quad(nan), "instances": quad(ok, chain), "stride": quad(ok, stride),
                  "specgloss": quad(ok, required)}.items():
    json.dump(doc, open(f"{d}/{name}.gltf", "w"))
PY
fail=0
check() {  # name, what the message must name
  local name=$1 mentions=$2
  printf '{"renderers":["forward","visbuffer"],"scenes":[{"gltf":"%s/%s.gltf"}],"resolutions":[[64,36]],"frames":1}\n' \
    "$dir" "$name" > "$dir/$name.json"
  # 4 GiB of address space: lavapipe's device fits, a loader allocating for
  # 2^40 instances does not.
  prlimit --as=$((4 << 30)) timeout 60 "$tallyd" capture --spec "$dir/$name.json" --out "$dir/$name.out.json" \
    > /dev/null 2> "$dir/$name.err"
  local rc=$?
  local msg; msg=$(cat "$dir/$name.err")
  if [ $rc -ne 1 ]; then echo "FAIL $name: exit $rc (want 1): $msg"; fail=1; return; fi
  if [[ "$msg" != *"$dir/$name.gltf"* || "$msg" != *"$mentions"* ]]; then
    echo "FAIL $name: message does not name the file and '$mentions': $msg"; fail=1; return
  fi
  if [ -e "$dir/$name.out.json" ]; then echo "FAIL $name: a result was written"; fail=1; return; fi
  echo "ok $name: $msg"
}
check nan "POSITION (accessor 0): vertex 1 is not finite"
check instances "over Tally's limit of 65536"
check stride "accessor 0: byteStride 8 of bufferView 0 is smaller than its element (12 bytes)"
check specgloss "requires extension KHR_materials_pbrSpecularGlossiness"
exit $fail

#!/bin/bash
# The runs listing's JSON from the old binary (schema 12) against the new one on the same rows
# (migrated to 13: aggregates backfilled, frame time computed from the samples) and on rows the
# new binary ingested itself (the same synthetic captures; created_at differs and is blanked).
#
#   benchmarks/listing_json_check.sh OLD_TALLYD NEW_TALLYD OLD_BENCH NEW_BENCH
#
# The listing's pages are also compared as the bytes sent (old and migrated database: the same rows).
# (tallyd and tally_bench_read_latency of each build; works in /tmp/rs-json; needs sqlite3, curl, python3)
set -e
OLD_TALLYD=$1; NEW_TALLYD=$2; OLD_BENCH=$3; NEW_BENCH=$4
TEMPLATE=$(cd "$(dirname "$0")/.." && pwd)/docs/data/sponza-protocol-h200.json.gz
mkdir -p /tmp/rs-json; cd /tmp/rs-json; rm -f old.db* mig.db* new.db*
# Both fills from copies here, where neither finds a data folder: a run's "shaders" (the hashes of
# the shader sources the binary finds beside it) would differ with where each binary lies.
cp "$OLD_BENCH" bench-old; cp "$NEW_BENCH" bench-new
./bench-old --template "$TEMPLATE" --db old.db --samples 4000 --requests 1 --seconds 1 > fill-old.txt 2>&1
./bench-new --template "$TEMPLATE" --db new.db --samples 4000 --requests 1 --seconds 1 > fill-new.txt 2>&1
cp old.db mig.db
dump() {  # tallyd db port out
  $1 serve --role api --db $2 --port $3 > serve-$3.log 2>&1 & pid=$!
  for i in $(seq 50); do curl -sf http://127.0.0.1:$3/api/runs?limit=1 >/dev/null && break; sleep 0.2; done
  python3 - "$3" "$4" <<'PY'
import json, sys, urllib.request
port, out = sys.argv[1], sys.argv[2]
get = lambda p: json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}{p}"))
pages, cursor, raw = [], None, open(out + ".raw", "wb")
while True:
    body = urllib.request.urlopen(f"http://127.0.0.1:{port}/api/runs?limit=50" + (f"&cursor={cursor}" if cursor else "")).read()
    raw.write(body + b"\n")  # the listing's bytes as sent
    page = json.loads(body)
    pages.append(page); cursor = page["next_cursor"]
    if not cursor: break
runs = [r for p in pages for r in p["runs"]]
one = {r["id"]: get(f"/api/runs/{r['id']}") for r in runs[::7]}
ids = [r["id"] for r in runs if r["sample_count"]][:3]
cmp = get("/api/compare?runs=" + ",".join(map(str, ids)))
def blank(x):
    if isinstance(x, dict): return {k: ("-" if k == "created_at" else blank(v)) for k, v in x.items()}
    if isinstance(x, list): return [blank(v) for v in x]
    return x
json.dump(blank({"pages": pages, "runs": one, "compare": cmp}), open(out, "w"), sort_keys=True, indent=1)
print(port, len(runs), "runs")
PY
  kill $pid; wait $pid || true
}
dump $OLD_TALLYD old.db 18471 before.json
dump $NEW_TALLYD mig.db 18472 after-migrated.json
dump $NEW_TALLYD new.db 18473 after-ingested.json
echo "schema: old.db $(sqlite3 old.db 'PRAGMA user_version'), mig.db $(sqlite3 mig.db 'PRAGMA user_version'), frame time stored in mig.db: $(sqlite3 mig.db 'SELECT COUNT(frame_time_source) FROM runs'), in new.db: $(sqlite3 new.db 'SELECT COUNT(frame_time_source) FROM runs') of $(sqlite3 new.db 'SELECT COUNT(*) FROM runs')"
cmp before.json after-migrated.json && echo "before == after (migrated): identical, $(wc -c < before.json) bytes"
cmp before.json.raw after-migrated.json.raw && echo "the listing's pages as sent, before == after (migrated): byte for byte, $(wc -c < before.json.raw) bytes"
cmp before.json after-ingested.json && echo "before == after (ingested by the new binary): identical"

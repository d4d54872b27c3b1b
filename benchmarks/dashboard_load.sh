#!/usr/bin/env bash
# Dashboard load time with many runs stored: fills a database with RUNS
# synthetic runs (10 samples each) through tally_bench_read_latency's fill
# (the real ingest), serves it with `tallyd serve --web web`, and times each
# view in Chromium (dashboard_load.mjs). Prints figures; asserts nothing.
#
#   benchmarks/dashboard_load.sh [BUILD_DIR=build] [RUNS=1000]
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
runs="${2:-1000}"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$build/benchmarks/tally_bench_read_latency" --samples $((runs * 10)) --requests 1 --seconds 1 \
  --db "$dir/tally.db" >"$dir/fill.log"
grep -i "fill\|stored" "$dir/fill.log" | head -3 || true
TALLYD="$build/server/tallyd" TALLY_WEB_ROOT="$PWD/web" TALLY_DB="$dir/tally.db" \
  CHROMIUM="${CHROMIUM:-/usr/bin/chromium}" node benchmarks/dashboard_load.mjs

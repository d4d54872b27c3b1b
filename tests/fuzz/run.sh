#!/usr/bin/env bash
# Runs one harness for SECONDS over its seeds: new inputs go to OUT/corpus,
# a crash, leak or UB report to OUT/ (crash-*, leak-*) and fails the run.
# Usage: run.sh HARNESS SEEDS OUT SECONDS [libFuzzer flags...]
set -euo pipefail
harness=$1 seeds=$2 out=$3 seconds=$4
shift 4
if [ ! -d "$seeds" ]; then
  echo "run.sh: no seeds in $seeds (cmake --build BUILD --target fuzz_corpus)" >&2
  exit 1
fi
mkdir -p "$out/corpus"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$(cd "$(dirname "$0")/.." && pwd)/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# -rss_limit_mb and -timeout: an input that takes more than 2 GiB or 25 s is
# a finding too (the daemon reads these inputs from its users).
exec "$harness" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=25 -max_len=1048576 \
  -print_final_stats=1 -artifact_prefix="$out/" "$@" "$out/corpus" "$seeds"

#!/usr/bin/env bash
# Runs every test: installs what is missing, builds, runs ctest (unit, SPIR-V
# corpus, lavapipe integration), then the SPIR-V layer again under
# AddressSanitizer + UndefinedBehaviorSanitizer, and the fuzz harnesses.
set -euo pipefail
cd "$(dirname "$0")/.."

phase_started=$(date +%s)
phases=()
free_mib() { df -Pm . | awk 'NR == 2 { print $4 }'; }
phase() {  # phase NAME: the time since the last call and the disk left, printed at the end
  local now
  now=$(date +%s)
  phases+=("$(printf '%-22s %5d s %8d MiB free' "$1" $((now - phase_started)) "$(free_mib)")")
  phase_started=$now
}
# A cold run (no build trees, an empty compiler cache) writes about 2.5 GiB
# besides what setup.sh installs (docs/benchmarks.md, "A cold run, end to
# end, and the disk it takes"); 8 GiB leaves room for -g builds. Say so
# before the build rather than let a linker fail on a full disk at the end.
if [ ! -d build ] && [ "$(free_mib)" -lt 8192 ]; then
  echo "test.sh: warning: $(free_mib) MiB free on $(df -P . | awk 'NR == 2 { print $6 }'); a cold run needs about 2.5 GiB, and more with TALLY_DEBUG_INFO=full" >&2
fi

bash scripts/setup.sh
phase "setup"
jobs=$(nproc)
# ccache (setup.sh installs it) where the machine keeps a cache: a build of a
# clone in any folder of this machine reuses the objects of earlier builds,
# paths being taken relative to the clone. A new machine builds everything.
launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1 CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-20G}"
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
# setup.sh installed every tool the suite needs, so a test that finds one
# missing (a Vulkan device, Xvfb, Chromium, PostgreSQL, Sponza in ../shared)
# fails here as under CI, instead of skipping (tests/support/strict.hpp).
export TALLY_TEST_STRICT=1

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTALLY_WERROR=ON "${launcher[@]}" >/dev/null
cmake --build build -j"$jobs"
phase "build"

# TALLY_TEST_LOAD=N: the tests run on a busy machine, N processes of
# stress-ng spinning on the CPU beside them from here to the end (the suite
# must pass so, without retries: docs/benchmarks.md, "The suite under load").
if [ -n "${TALLY_TEST_LOAD:-}" ]; then
  command -v stress-ng >/dev/null || { echo "TALLY_TEST_LOAD needs stress-ng (scripts/setup.sh installs it)" >&2; exit 1; }
  stress-ng --cpu "$TALLY_TEST_LOAD" --timeout 4h --quiet &
  load_pid=$!
  trap 'kill "$load_pid" 2>/dev/null || true' EXIT
  echo "test.sh: the tests run beside stress-ng --cpu $TALLY_TEST_LOAD (pid $load_pid)"
fi
tests_started=$(date +%s)

ctest --test-dir build --output-on-failure -j"$jobs"
phase "tests"

# Sanitizer build, with clang: the targets whose input is untrusted SPIR-V,
# and the fuzz harnesses (TALLY_FUZZ: ASan, UBSan and libFuzzer; tests/fuzz/).
# -O1: the fuzzers run several times faster than at -O0. -g1: line tables,
# all a sanitizer's report needs, in a quarter of -g's disk.
if [ -f build-asan/CMakeCache.txt ] && ! grep -q '^CMAKE_CXX_COMPILER:.*clang' build-asan/CMakeCache.txt; then
  rm -rf build-asan  # a tree configured with gcc before the switch to clang
fi
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g1 -O1" \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DTALLY_FUZZ=ON -DTALLY_BUILD_BENCHMARKS=OFF \
  "${launcher[@]}" >/dev/null
cmake --build build-asan -j"$jobs" --target tally_unit_tests tally_corpus_tests tallyd \
  fuzz_spirv fuzz_gltf fuzz_spec fuzz_http fuzz_ingest fuzz_corpus
phase "sanitizer build"
# The corpus digests are the gcc build's output words (tests/spirv/corpus_test.cpp):
# clang numbers some footprint ids in another order, so they are checked above only.
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
LSAN_OPTIONS=suppressions="$PWD/tests/lsan.supp":print_suppressions=0 \
UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan -L spirv -E '^CorpusDigests[.]' --output-on-failure -j"$jobs"
phase "sanitizer tests"
# Each harness for TALLY_FUZZ_SECONDS (60) over its seeds; a crash, leak or
# UB fails it, the input left in build-asan/fuzz/runs/<harness>/.
ctest --test-dir build-asan -L fuzz --output-on-failure -j"$jobs"
phase "fuzz"
echo "test.sh: the tests took $(( $(date +%s) - tests_started )) s${TALLY_TEST_LOAD:+ beside stress-ng --cpu $TALLY_TEST_LOAD}"
echo "test.sh: phase times"
printf '  %s\n' "${phases[@]}"

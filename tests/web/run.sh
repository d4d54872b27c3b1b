#!/usr/bin/env bash
# Runs the dashboard's browser tests (dashboard.test.mjs, application.test.mjs,
# hosts.test.mjs, crossover.test.mjs, heatmap.test.mjs, alerts.test.mjs,
# glance.test.mjs, shader.test.mjs) with node's test runner. ctest calls it as:
# run.sh TALLYD WEB_ROOT SCREENSHOT_DIR [FILE.test.mjs ...] (one file per ctest test; all without).
# Without node, Chromium or the npm packages (scripts/setup.sh installs them)
# it skips (exit 77), except where tests are strict (CI=true, or
# TALLY_TEST_STRICT=1 from scripts/test.sh), where a missing tool is a failure.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
export TALLYD="$1" TALLY_WEB_ROOT="$2" TALLY_SCREENSHOTS="$3"
export CHROMIUM="${CHROMIUM:-/usr/bin/chromium}"

missing=()
command -v node >/dev/null || missing+=("node")
[ -x "$CHROMIUM" ] || missing+=("chromium ($CHROMIUM)")
[ -d "$here/node_modules/playwright-core" ] || missing+=("playwright-core (npm ci in tests/web)")
[ -f "$TALLY_WEB_ROOT/vendor/chart.umd.min.js" ] || missing+=("web/vendor/chart.umd.min.js (scripts/setup.sh)")
if [ ${#missing[@]} -gt 0 ]; then
  echo "browser tests: missing ${missing[*]}; run scripts/setup.sh" >&2
  if [ "${CI:-}" = "true" ] || [ "${TALLY_TEST_STRICT:-}" = "1" ]; then exit 1; fi
  exit 77
fi

cd "$here"
files=("${@:4}")
if [ ${#files[@]} -eq 0 ]; then
  files=(dashboard.test.mjs application.test.mjs hosts.test.mjs crossover.test.mjs heatmap.test.mjs alerts.test.mjs glance.test.mjs shader.test.mjs)
fi
exec node --test --test-reporter=spec "${files[@]}"

#!/usr/bin/env bash
# Browser test of the HTML survey report: simulates the demo survey, runs it, and checks its
# report/ in headless Chromium (report_browser_test.mjs through playwright-core).
#
#   run_report_browser_test.sh <roadsurvey-binary> <work_dir> <artifact_dir>
#
#   ROADSURVEY_REPORT_DIR=<dir>  test that report folder instead (needs <dir>/../damage.geojson);
#                                the binary is then not used
#   CHROMIUM=<path>              the Chromium to use (default: chromium on PATH)
#
# Exit 0 passed, 1 failed, 2 bad usage, 77 skipped (no Chromium).
# playwright-core is installed with `npm ci` into <work_dir>/node_modules from the lock file here,
# and reused while that lock file is unchanged (npm needs the registry or its cache the first time).
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

if [ $# -ne 3 ]; then
  echo "usage: $0 <roadsurvey-binary> <work_dir> <artifact_dir>" >&2
  exit 2
fi
bin=$1
work=$2
artifacts=$3

# --- prerequisites: a machine without a browser skips the test; Node.js and npm come with ./setup.sh
chromium=${CHROMIUM:-$(command -v chromium || true)}
if [ -z "$chromium" ] || [ ! -x "$chromium" ]; then
  echo "SKIP: chromium not installed (apt-get install chromium)"
  exit 77
fi
for tool in node npm; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "FAIL: $tool not installed: run ./setup.sh (Debian packages nodejs, npm)" >&2
    exit 1
  fi
done
node_major=$(node -p 'process.versions.node.split(".")[0]')
if [ "$node_major" -lt 18 ]; then
  echo "FAIL: playwright-core needs Node.js 18 or newer (found $(node --version))" >&2
  exit 1
fi

mkdir -p "$work" "$artifacts"
work=$(cd "$work" && pwd)
artifacts=$(cd "$artifacts" && pwd)

# --- playwright-core, pinned by package-lock.json; Chromium is the system's, never downloaded
install_playwright() {
  local stamp=$work/node_modules/.roadsurvey-report-test.lock
  if [ -f "$stamp" ] && cmp -s "$here/package-lock.json" "$stamp"; then
    echo "playwright-core: reusing $work/node_modules"
    return
  fi
  echo "playwright-core: npm ci in $work (log: $work/npm.log)"
  cp "$here/package.json" "$here/package-lock.json" "$work/"
  if ! (cd "$work" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund) >"$work/npm.log" 2>&1; then
    echo "FAIL: npm ci could not install playwright-core; its output:" >&2
    cat "$work/npm.log" >&2
    exit 1
  fi
  cp "$here/package-lock.json" "$stamp"
}
install_playwright
# Node resolves playwright-core from the test script's folder: run a copy beside node_modules.
cp "$here/report_browser_test.mjs" "$work/"

# --- the report under test: the demo survey's, unless one is named
if [ -n "${ROADSURVEY_REPORT_DIR:-}" ]; then
  report=$ROADSURVEY_REPORT_DIR
  echo "report: $report (ROADSURVEY_REPORT_DIR)"
else
  if [ ! -x "$bin" ]; then
    echo "FAIL: roadsurvey binary not found or not executable: $bin" >&2
    exit 1
  fi
  demo=$work/demo
  echo "simulating the demo survey in $demo"
  rm -rf "$demo"
  "$bin" simulate "$demo" --progress quiet
  echo "running $demo/survey.json"
  "$bin" run "$demo/survey.json" --progress quiet --surface.mesh false
  report=$demo/out/report
fi
if [ ! -f "$report/index.html" ]; then
  echo "FAIL: no report at $report (index.html missing)" >&2
  exit 1
fi

echo "checking the report in $chromium; artifacts in $artifacts"
CHROMIUM=$chromium node "$work/report_browser_test.mjs" "$report" "$artifacts"

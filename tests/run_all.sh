#!/usr/bin/env bash
# The whole test suite: a short fuzzing pass over every binary reader, then
# every unit and end-to-end test through CTest.
#   tests/run_all.sh [BUILD_DIR=build]     ROADSURVEY_FUZZ_SECONDS=0 skips fuzzing
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
fuzz_seconds=${ROADSURVEY_FUZZ_SECONDS:-20}
if [ ! -d "${ROADSURVEY_DATA:-$root/../shared/data}" ]; then
  echo "note: ../shared/data not found: tests on real data will be skipped (set ROADSURVEY_DATA)"
fi
if [ "$fuzz_seconds" -gt 0 ]; then
  "$root/tests/fuzz/run_fuzzers.sh" "$build-fuzz" "$fuzz_seconds"
fi
ctest --test-dir "$build" --output-on-failure -j2

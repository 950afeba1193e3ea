#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) in BUILD_DIR and runs
# each for SECONDS over seeds taken from ../shared/data (or $ROADSURVEY_DATA).
# Fails on any crash, sanitizer report, hang (> 10 s per input) or > 2 GB RSS.
#   tests/fuzz/run_fuzzers.sh [BUILD_DIR=build-fuzz] [SECONDS=20]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-build-fuzz}
seconds=${2:-20}
data=${ROADSURVEY_DATA:-$root/../shared/data}
fuzzers=(ulog_fuzz dataflash_fuzz csv_fuzz gpx_fuzz srt_fuzz trajectory_io_fuzzer)

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DROADSURVEY_FUZZ=ON -DROADSURVEY_BUILD_TESTS=OFF -DROADSURVEY_NATIVE=OFF >/dev/null
cmake --build "$build" --target "${fuzzers[@]}" -j2 >/dev/null

# seed FUZZER GLOB...: first 16 KiB of each matching sample (whole files slow libFuzzer down).
seed() {
  local dir="$build/corpus/$1"; shift
  rm -rf "$dir"; mkdir -p "$dir"
  local i=0 f
  for f in "$@"; do
    [ -f "$f" ] || continue
    head -c 16384 "$f" > "$dir/seed_$i"; i=$((i + 1))
  done
  echo "$i"
}

shopt -s nullglob globstar
passed=0 failed=0
for fz in "${fuzzers[@]}"; do
  case "$fz" in
    ulog_fuzz) n=$(seed "$fz" "$data"/px4_ulog/**/*.ulg) ;;
    dataflash_fuzz) n=$(seed "$fz" "$data"/ardupilot_dataflash/**/*.BIN) ;;
    csv_fuzz) n=$(seed "$fz" "$data"/kitti_raw_tiny/**/oxts/data/*.txt "$root"/formats/flight_log/*.md) ;;
    gpx_fuzz) n=$(seed "$fz" "$data"/gpx_tracks/**/*.gpx) ;;
    srt_fuzz) n=$(seed "$fz" "$data"/dji_srt/samples/*.SRT "$data"/dji_srt/samples/*.srt) ;;
    trajectory_io_fuzzer) n=$(seed "$fz" "$data"/kitti_euroc_trajectories/**/*.txt "$data"/kitti_euroc_trajectories/**/*.csv) ;;
  esac
  log="$build/$fz.log"
  if "$build/$(find "$build" -name "$fz" -type f -printf '%P\n' | head -1)" "$build/corpus/$fz" \
       -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 >"$log" 2>&1; then
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    echo "fuzz $fz: ok, $runs inputs in ${seconds} s ($n seeds)"
    passed=$((passed + 1))
  else
    echo "fuzz $fz: FAILED (see $log)"; tail -30 "$log"
    failed=$((failed + 1))
  fi
done
echo "fuzz: $passed passed, $failed failed"
[ "$failed" -eq 0 ]

#!/bin/bash
# Long libFuzzer runs of every target, one after the other (docs/fuzzing.md, "Long runs"):
# builds the targets in BUILD (configured as in docs/fuzzing.md), then runs each for SECONDS
# at nice 19 from the committed seeds, new inputs and logs in OUT/<target>. Prints one line
# per target: executions, coverage, and whether it found anything (a crash-* / timeout-*
# file in OUT/<target>/art).
#   bench/fuzz_long.sh build-fuzz /tmp/fuzzlong 480
set -euo pipefail
build=$1 out=$2 seconds=${3:-480}
src=$(cd "$(dirname "$0")/.." && pwd)
cmake --build "$build" -j"$(nproc)" --target vgr_fuzzers > /dev/null
for t in fuzz_robot_request fuzz_robot_dialects fuzz_robot_reply fuzz_modbus_adu fuzz_modbus_map \
         fuzz_cell_config fuzz_job_file fuzz_calib_files; do
  mkdir -p "$out/$t/corpus" "$out/$t/art"
  load=$(cut -d' ' -f1 /proc/loadavg)
  (cd "$out/$t/art" && nice -n 19 "$build/bin/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -print_final_stats=1 "$out/$t/corpus" "$src/tests/fuzz/corpus/$t" > "$out/$t/log.txt" 2>&1) || true
  runs=$(grep -h 'stat::number_of_executed_units' "$out/$t/log.txt" | awk '{print $2}')
  cov=$(grep -ho 'cov: [0-9]*' "$out/$t/log.txt" | tail -1 | awk '{print $2}')
  found=$(ls "$out/$t/art" | wc -l)
  echo "$t executions ${runs:-?} coverage ${cov:-?} findings $found (load at start $load)"
done

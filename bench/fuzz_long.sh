#!/bin/sh
# Runs every libFuzzer target (tests/fuzz) for longer than the test suite does and prints, per
# target, the executions, executions per second, corpus size and crashes. Each target stops at
# SECONDS or RUNS executions, whichever comes first; crashing inputs are kept in OUT/<target>-*.
# Build the targets first: cmake --build build/release --target fuzz_all (or each fuzz_* name).
#   bench/fuzz_long.sh [BUILD_DIR=build/release] [SECONDS=300] [RUNS=10000000] [OUT=/tmp/pbdam-fuzz]
#                      [TARGETS="fuzz_manifest fuzz_checkpoint ..." (default: every one built)]
# The machine may be shared: run it under `nice`.
set -u
build=${1:-build/release}
seconds=${2:-300}
runs=${3:-10000000}
out=${4:-/tmp/pbdam-fuzz}
targets=${5:-}
src=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
crashes_total=0
printf '%-20s %12s %10s %8s %8s %8s\n' target executions exec/s seconds corpus crashes
for exe in "$build"/tests/fuzz/bin/fuzz_*; do
  [ -x "$exe" ] || continue
  name=$(basename "$exe")
  if [ -n "$targets" ]; then
    case " $targets " in *" $name "*) ;; *) continue ;; esac
  fi
  seeds=$src/tests/fuzz/corpus/${name#fuzz_}
  corpus=$out/${name}_corpus
  mkdir -p "$corpus"
  log=$out/$name.log
  # The same limits as the test suite's run of the target (tests/fuzz/CMakeLists.txt).
  case $name in
    fuzz_texture_tile) max_len=70000 ;;
    fuzz_checkpoint) max_len=65536 ;;
    fuzz_face_file) max_len=8192 ;;
    fuzz_serve_query) max_len=1024 ;;
    *) max_len=4096 ;;
  esac
  start=$(date +%s)
  "$exe" -max_total_time="$seconds" -runs="$runs" -timeout=10 -rss_limit_mb=2048 \
    -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$out/$name-" \
    "$corpus" $( [ -d "$seeds" ] && echo "$seeds" ) >"$log" 2>&1
  status=$?
  elapsed=$(( $(date +%s) - start ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  size=$(ls "$corpus" | wc -l)
  crashes=$(ls "$out" | grep -c "^$name-\(crash\|leak\|timeout\|oom\)-" || true)
  [ "$status" -ne 0 ] && [ "$crashes" -eq 0 ] && crashes=1
  crashes_total=$((crashes_total + crashes))
  printf '%-20s %12s %10s %8s %8s %8s\n' "$name" "${execs:-?}" "${rate:-?}" "$elapsed" "$size" \
    "$crashes"
done
echo "crashes in all targets: $crashes_total (logs and inputs in $out)"
[ "$crashes_total" -eq 0 ]

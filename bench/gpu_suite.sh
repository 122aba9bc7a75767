#!/usr/bin/env bash
# The GPU suite: the Mars flight (bench/paths/mars_flight.csv, prefetch off, morph on) replayed by
# `pbdam bench` at 640x480 with a 3 px tolerance, 1920x1080 with 1 px and 3840x2160 with 1 px, each
# with 1 and 2 frames in flight and with the device's selection drawing its own list (--selection
# gpu --draws indirect), then ONE markdown table from the runs' summary.json: size, tolerance,
# mode, fps, frame p50 ms, GPU draw p50 ms, gpu_busy_fraction, and per size the frame rate with 2
# frames in flight over that with 1. Meant for a machine with a GPU (docs/performance.md "GPU
# suite"); on lavapipe it runs too, slowly at the large sizes (use --frames).
#   bench/gpu_suite.sh [OPTIONS] [DATASET] [-- BENCH_ARGS...]
#     DATASET          a dataset directory (default build/testdata/mola, the MOLA test dataset)
#     --device D       passed to every bench (an index or part of a name, as `pbdam devices`
#                      lists them); default: pbdam's choice, PBDAM_DEVICE if set
#     --frames N       replay only the path's first N poses (a shortened copy in OUTDIR)
#     --out OUTDIR     where the reports go, one directory per run (default build/gpu_suite)
#     --pbdam PATH     the pbdam binary (default $PBDAM, else build/release/tools/pbdam, else
#                      pbdam on PATH: what ../shared/tools/gpu-bundle.sh's gpu-env.sh sets up)
#     --table-only     run nothing: print the table of the reports already in OUTDIR
#     BENCH_ARGS       more options for every bench (e.g. --gpu-cache-mib 512)
# The table is also written to OUTDIR/table.md. A run that fails is logged in OUTDIR/RUN.log,
# shown as failed in the table, and makes the exit status 1.
# Environment: PBDAM_GPU_SUITE_NO_INFLIGHT=1 leaves --frames-in-flight out of the commands (for a
# pbdam without that option: the two in-flight rows are then the same setting).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage() {
  sed -n '/^#   bench\/gpu_suite.sh/,/^# Environment/p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2
  exit 2
}
dataset="$root/build/testdata/mola"
device=""
frames=""
out="$root/build/gpu_suite"
pbdam=${PBDAM:-}
table_only=0
extra=()
while [ $# -gt 0 ]; do
  case $1 in
    --device) [ $# -ge 2 ] || usage; device=$2; shift ;;
    --frames) [ $# -ge 2 ] || usage; frames=$2; shift ;;
    --out) [ $# -ge 2 ] || usage; out=$2; shift ;;
    --pbdam) [ $# -ge 2 ] || usage; pbdam=$2; shift ;;
    --table-only) table_only=1 ;;
    -h | --help) usage ;;
    --) shift; extra=("$@"); break ;;
    -*) echo "gpu_suite.sh: unknown option '$1'" >&2; usage ;;
    *) dataset=$1 ;;
  esac
  shift
done
if [ -n "$frames" ] && ! [[ "$frames" =~ ^[1-9][0-9]*$ ]]; then
  echo "gpu_suite.sh: --frames '$frames': expected a positive number of poses" >&2
  exit 2
fi
if [ -z "$pbdam" ]; then
  if [ -x "$root/build/release/tools/pbdam" ]; then
    pbdam="$root/build/release/tools/pbdam"
  else
    pbdam=$(command -v pbdam || true)
  fi
fi
command -v jq >/dev/null || { echo "gpu_suite.sh: jq not found" >&2; exit 2; }
mkdir -p "$out"

# The runs: NAME WIDTH HEIGHT TOLERANCE MODE, in table order.
runs=()
for size in "640 480 3" "1920 1080 1" "3840 2160 1"; do
  read -r w h tol <<<"$size"
  for mode in inflight1 inflight2 indirect; do runs+=("${w}x${h}_$mode $w $h $tol $mode"); done
done
mode_name() {
  case $1 in
    inflight1) echo "in-flight 1" ;;
    inflight2) echo "in-flight 2" ;;
    indirect) echo "gpu indirect" ;;
  esac
}

failed=0
if [ "$table_only" = 0 ]; then
  [ -x "$pbdam" ] || { echo "gpu_suite.sh: no pbdam binary at '$pbdam' (--pbdam)" >&2; exit 2; }
  [ -f "$dataset/manifest.json" ] || { echo "gpu_suite.sh: $dataset is not a dataset" >&2; exit 2; }
  path="$root/bench/paths/mars_flight.csv"
  if [ -n "$frames" ]; then
    head -n "$((frames + 1))" "$path" >"$out/path.csv"  # the header and the first N poses
    path="$out/path.csv"
  fi
  common=(--path "$path" --prefetch off --morph on --quiet)
  [ -z "$device" ] || common+=(--device "$device")
  echo "pbdam: $pbdam; dataset: $dataset; $(($(wc -l <"$path") - 1)) poses; reports in $out" >&2
  for run in "${runs[@]}"; do
    read -r name w h tol mode <<<"$run"
    args=(bench "$dataset" --out "$out/$name" --width "$w" --height "$h" --tolerance-px "$tol")
    case $mode in
      inflight1) [ "${PBDAM_GPU_SUITE_NO_INFLIGHT:-0}" = 1 ] || args+=(--frames-in-flight 1) ;;
      inflight2) [ "${PBDAM_GPU_SUITE_NO_INFLIGHT:-0}" = 1 ] || args+=(--frames-in-flight 2) ;;
      indirect) args+=(--selection gpu --draws indirect) ;;
    esac
    args+=("${common[@]}" "${extra[@]}")
    echo "+ pbdam ${args[*]}" >&2
    rm -rf "${out:?}/$name"
    if ! "$pbdam" "${args[@]}" >"$out/$name.log" 2>&1; then
      echo "gpu_suite.sh: $name failed (log: $out/$name.log):" >&2
      tail -n 5 "$out/$name.log" >&2
      failed=1
    fi
  done
fi

# The table: one row per run, from its summary.json (the run with prefetch off and morph on).
row() {  # NAME TOLERANCE MODE RATIO
  local json="$out/$1/summary.json"
  if [ ! -f "$json" ]; then
    printf '| %s | %s px | %s | failed | | | | |\n' "${1%%_*}" "$2" "$(mode_name "$3")"
    return
  fi
  jq -r '.width as $w | .height as $h | .runs[] | select(.prefetch == "off" and .morph == "on") |
    [$w, $h, .fps_mean, .frame_ms_p50, .draw_ms_p50, .gpu_busy_fraction] | @tsv' "$json" |
    awk -F'\t' -v tol="$2" -v mode="$(mode_name "$3")" -v ratio="$4" '{
      printf "| %dx%d | %s px | %s | %.1f | %.2f | %.2f | %.3f | %s |\n", $1, $2, tol, mode, $3, $4,
             $5, $6, ratio }'
}
fps() {  # NAME: the run's frame rate, or nothing
  local json="$out/$1/summary.json"
  [ -f "$json" ] && jq -r '.runs[] | select(.prefetch == "off" and .morph == "on") | .fps_mean' "$json"
}
{
  echo "| size | tolerance | mode | fps | frame p50 ms | GPU draw p50 ms | gpu_busy_fraction | fps in-flight 2 / in-flight 1 |"
  echo "|---|---|---|---|---|---|---|---|"
  for run in "${runs[@]}"; do
    read -r name w h tol mode <<<"$run"
    ratio=""
    if [ "$mode" = inflight2 ]; then
      one=$(fps "${w}x${h}_inflight1" || true)
      two=$(fps "$name" || true)
      if [ -n "$one" ] && [ -n "$two" ]; then
        ratio=$(awk -v a="$two" -v b="$one" 'BEGIN { if (b > 0) printf "%.2fx", a / b }')
      fi
    fi
    row "$name" "$tol" "$mode" "$ratio"
  done
} | tee "$out/table.md"
exit "$failed"

#!/usr/bin/env bash
# Larger than memory, for real: the large-data dataset (2.24 GB, bench/large_data.sh, built or
# reused) flown cold along the Mars flight (bench/paths/mars_flight.csv) at WIDTHxHEIGHT inside a
# memory cgroup that counts the page cache, capped at CAP_MIB (default 256: 9x smaller than the
# data), in paging and in no-stall mode, each with prefetch off and on; and the same four
# flights uncapped. With PAPER_DATASET set (bench/paper_scale.sh's output) it flies
# that one too under PAPER_CAP_MIB (default 1024). Then, unless SERVE_SECONDS=0, `pbdam serve`
# under SERVE_CAP_MIB (default 512) with the soak's mixed load (pbdam_serve_soak) for
# SERVE_SECONDS (default 600), and uncapped for the same time.
#   bench/larger_than_memory.sh [OUTDIR]      (default build/ltm)
# FLY_LARGE=0 skips the large-data flights (to fly only the paper-scale dataset).
# Environment: CAP_MIB, FLY_LARGE, PAPER_DATASET, PAPER_CAP_MIB, SERVE_CAP_MIB, SERVE_SECONDS, WIDTH (1280),
# HEIGHT (720), LARGE_OUT (where bench/large_data.sh keeps the dataset, default build/large).
# The cap is a child cgroup of this shell's memory cgroup: cgroup v2 (memory.max, swap off) where
# /sys/fs/cgroup is the unified hierarchy, else cgroup v1 (memory.limit_in_bytes and, where the
# kernel accounts swap, memory.memsw.limit_in_bytes); it needs root or a delegated cgroup and
# refuses, saying which, when neither can be made. Each capped run reports the cgroup's peak
# usage and its OOM kills; every run its summary.json figures (one line each, and a table in
# OUTDIR/table.md).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-"$root/build/ltm"}
cap=${CAP_MIB:-256}
width=${WIDTH:-1280}
height=${HEIGHT:-720}
serveCap=${SERVE_CAP_MIB:-512}
serveSeconds=${SERVE_SECONDS:-600}
bin="$root/build/release"
pbdam="$bin/tools/pbdam"
mkdir -p "$out"

# --- the cap: a child of this shell's memory cgroup ---
cgroup_kind=""
cgroup_dir=""
make_cgroup() {  # make_cgroup NAME MIB: sets cgroup_dir
  local name=$1 mib=$2 self
  if [ -f /sys/fs/cgroup/cgroup.controllers ]; then
    self=$(awk -F: '$1 == "0" { print $3 }' /proc/self/cgroup)
    cgroup_kind="cgroup v2"
    cgroup_dir="/sys/fs/cgroup${self%/}/$name"
    mkdir -p "$cgroup_dir" 2>/dev/null || return 1
    echo $((mib * 1048576)) > "$cgroup_dir/memory.max" || return 1
    [ -f "$cgroup_dir/memory.swap.max" ] && echo 0 > "$cgroup_dir/memory.swap.max"
  elif [ -d /sys/fs/cgroup/memory ]; then
    self=$(awk -F: '$2 ~ /(^|,)memory(,|$)/ { print $3 }' /proc/self/cgroup)
    cgroup_kind="cgroup v1"
    cgroup_dir="/sys/fs/cgroup/memory${self%/}/$name"
    mkdir -p "$cgroup_dir" 2>/dev/null || return 1
    echo $((mib * 1048576)) > "$cgroup_dir/memory.limit_in_bytes" || return 1
    if [ -f "$cgroup_dir/memory.memsw.limit_in_bytes" ]; then
      echo $((mib * 1048576)) > "$cgroup_dir/memory.memsw.limit_in_bytes" || true
    fi
  else
    return 1
  fi
}
cgroup_peak_mib() {
  local f
  for f in memory.peak memory.max_usage_in_bytes; do
    [ -f "$cgroup_dir/$f" ] && { echo $(($(cat "$cgroup_dir/$f") / 1048576)); return; }
  done
  echo "?"
}
cgroup_oom_kills() {
  local f
  for f in memory.events memory.oom_control; do
    if [ -f "$cgroup_dir/$f" ]; then
      awk '$1 == "oom_kill" { print $2; found = 1 } END { if (!found) print 0 }' "$cgroup_dir/$f"
      return
    fi
  done
  echo "?"
}
remove_cgroup() { [ -n "$cgroup_dir" ] && rmdir "$cgroup_dir" 2>/dev/null || true; }
trap remove_cgroup EXIT

if ! make_cgroup "pbdam-cap-$$" "$cap"; then
  echo "larger_than_memory: cannot make a memory cgroup here (${cgroup_kind:-no memory controller}" \
       "at ${cgroup_dir:-/sys/fs/cgroup}): run as root or in a delegated cgroup" >&2
  exit 2
fi
remove_cgroup
echo "caps: $cgroup_kind child cgroups of this shell's (the page cache is counted)"

# --- the datasets ---
large=$(LARGE_BUILD_ONLY=1 "$root/bench/large_data.sh" "${LARGE_OUT:-$root/build/large}" | tail -1)
echo "large-data dataset: $large, $(($(du -sb "$large" | cut -f1) / 1048576)) MB"
path="$root/bench/paths/mars_flight.csv"

: > "$out/table.md"
echo "| dataset | cap | mode | prefetch | exit | fps | frame p99 ms | faults (after 1st) | data stalls | frames below full depth | triangles / frame | paged in MB/s | prefetched: used / evicted before use | node chunk reads | peak RSS MiB | cgroup peak MiB | OOM kills |" >> "$out/table.md"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|" >> "$out/table.md"

fly() {  # fly NAME DATASET CAP_MIB|none MODE PREFETCH
  local name=$1 dataset=$2 capMib=$3 mode=$4 prefetch=$5 report="$out/$1" status=0 peak="-" kills="-"
  rm -rf "$report"
  local cmd=("$pbdam" bench "$dataset" --path "$path" --out "$report" --cold --width "$width"
             --height "$height" --mode "$mode" --prefetch "$prefetch" --quiet)
  if [ "$capMib" = none ]; then
    "${cmd[@]}" > "$report.log" 2>&1 || status=$?
  else
    make_cgroup "pbdam-$name-$$" "$capMib"
    sh -c 'echo $$ > "$0/cgroup.procs" && exec "$@"' "$cgroup_dir" "${cmd[@]}" \
      > "$report.log" 2>&1 || status=$?
    peak=$(cgroup_peak_mib)
    kills=$(cgroup_oom_kills)
    remove_cgroup
    cgroup_dir=""
  fi
  python3 - "$report/summary.json" "$name" "$capMib" "$mode" "$prefetch" "$status" "$peak" \
    "$kills" "$out/table.md" <<'PY'
import json, os, sys
summary, name, cap, mode, prefetch, status, peak, kills, table = sys.argv[1:]
row = {k: "-" for k in ("fps", "p99", "faults", "stalls", "capped", "tris", "paged", "used",
                        "chunks", "rss")}
if os.path.exists(summary) and status == "0":
    r = json.load(open(summary))["runs"][0]
    seconds = r["frames"] / r["fps_mean"] if r["fps_mean"] else 0
    row = {"fps": f"{r['fps_mean']:.1f}", "p99": f"{r['frame_ms_p99']:.1f}",
           "faults": f"{r['render_thread_major_faults']} ({r['render_thread_major_faults_after_first_frame']})",
           "stalls": str(r["data_stalls"]),
           "capped": f"{r['frames_below_full_depth']} of {r['frames']}",
           "tris": f"{r['triangles_per_frame_mean']:,.0f}",
           "used": (f"{r['prefetch_ranges_used']} / {r['prefetch_ranges_evicted_before_use']}"
                    if prefetch == "on" else "-"),
           "chunks": str(r["node_chunk_reads"]) if r["node_tables_paged"] else "whole",
           "paged": f"{r['bytes_paged_in'] / 1048576 / seconds:.1f}" if seconds else "-",
           "rss": f"{r['peak_rss_mib']:.0f}"}
line = (f"| {name.split('-')[0]} | {cap} | {mode} | {prefetch} | "
        f"{status} | {row['fps']} | {row['p99']} | {row['faults']} | {row['stalls']} | "
        f"{row['capped']} | {row['tris']} | {row['paged']} | {row['used']} | {row['chunks']} | "
        f"{row['rss']} | {peak} | {kills} |")
print(f"{name}: " + line)
open(table, "a").write(line + "\n")
PY
}

for capMib in "$cap" none; do
  [ "${FLY_LARGE:-1}" = 0 ] && break
  tag=$([ "$capMib" = none ] && echo uncapped || echo "cap${capMib}")
  fly "large-$tag-paging-off" "$large" "$capMib" paging off
  fly "large-$tag-paging-on" "$large" "$capMib" paging on
  fly "large-$tag-nostall-off" "$large" "$capMib" no-stall off
  fly "large-$tag-nostall-on" "$large" "$capMib" no-stall on
done
if [ -n "${PAPER_DATASET:-}" ]; then
  for capMib in "${PAPER_CAP_MIB:-1024}" none; do
    tag=$([ "$capMib" = none ] && echo uncapped || echo "cap${capMib}")
    fly "paper-$tag-paging-off" "$PAPER_DATASET" "$capMib" paging off
    fly "paper-$tag-paging-on" "$PAPER_DATASET" "$capMib" paging on
    fly "paper-$tag-nostall-off" "$PAPER_DATASET" "$capMib" no-stall off
    fly "paper-$tag-nostall-on" "$PAPER_DATASET" "$capMib" no-stall on
  done
fi

# Faults and frame time along the flight, capped against uncapped (docs/performance.md shows it).
[ "${FLY_LARGE:-1}" = 0 ] || "$root/bench/plot_larger_than_memory.py" "$out/flight.svg" \
  "$cap MiB paging, prefetch off=$out/large-cap$cap-paging-off" \
  "$cap MiB paging, prefetch on=$out/large-cap$cap-paging-on" \
  "$cap MiB no-stall, prefetch on=$out/large-cap$cap-nostall-on" \
  "uncapped paging, prefetch off=$out/large-uncapped-paging-off" \
  "uncapped paging, prefetch on=$out/large-uncapped-paging-on" || true
echo "plot: $out/flight.svg"
if [ -n "${PAPER_DATASET:-}" ]; then
  pcap=${PAPER_CAP_MIB:-1024}
  "$root/bench/plot_larger_than_memory.py" "$out/flight-paper.svg" \
    "$pcap MiB paging, prefetch off=$out/paper-cap$pcap-paging-off" \
    "$pcap MiB paging, prefetch on=$out/paper-cap$pcap-paging-on" \
    "$pcap MiB no-stall, prefetch on=$out/paper-cap$pcap-nostall-on" \
    "uncapped paging, prefetch off=$out/paper-uncapped-paging-off" \
    "uncapped paging, prefetch on=$out/paper-uncapped-paging-on" || true
  echo "plot: $out/flight-paper.svg"
fi

if [ "$serveSeconds" != 0 ]; then
  soak="$bin/bench/pbdam_serve_soak"
  for capMib in "$serveCap" none; do
    log="$out/serve-$capMib.log"
    if [ "$capMib" = none ]; then
      "$soak" "$pbdam" "$large" --duration-s "$serveSeconds" > "$log" 2>&1 || echo "serve soak: exit $?" >> "$log"
      echo "serve uncapped: $(tail -3 "$log" | tr '\n' ' ')"
    else
      make_cgroup "pbdam-serve-$$" "$capMib"
      sh -c 'echo $$ > "$0/cgroup.procs" && exec "$@"' "$cgroup_dir" "$soak" "$pbdam" "$large" \
        --duration-s "$serveSeconds" > "$log" 2>&1 || echo "serve soak: exit $?" >> "$log"
      echo "serve under ${capMib} MiB: cgroup peak $(cgroup_peak_mib) MiB, OOM kills $(cgroup_oom_kills);" \
           "$(tail -3 "$log" | tr '\n' ' ')"
      remove_cgroup
      cgroup_dir=""
    fi
  done
fi
echo "table: $out/table.md"

#!/usr/bin/env bash
# Distributed build scaling (docs/builder.md "Distributed build"): builds one dataset
# with several RANKSxTHREADS configurations through mpirun, side by side in one run, and reports
# wall time, lattice and source samples/s, parallel efficiency against the 1x1 run (when
# included: T1 / (ranks·threads·T)), CPU seconds of all ranks together (on a shared machine the
# honest measure of what distribution costs: work efficiency = CPU(1x1) / CPU), peak RSS of
# every rank, the dataset size with and without patch compression, the load average, and
# whether all outputs are byte-identical. A script, not a test: it takes minutes to hours.
#
#   bench/mpi_build.sh [--dem FILE] [--planet P] [--levels N] [--configs "1x1 1x2 2x1"]
#                      [--keep DIR] [-- extra pbdam build options]
#
# Defaults: MOLA 4 px/deg from ../shared/data, --levels 12 (2048 cells per face side with the
# default 33-vertex leaves: 25 M lattice samples), configurations 1x1 1x2 2x1. The paper's scale
# is 6 faces of ~13,313² (a 16384-cell lattice: --levels 18, or a fractal-upsampled DEM such as
# pbdam_fractal_dem's with --levels auto); see README "Performance" for what that needs.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
pbdam="$root/build/release/tools/pbdam"
dem="$root/../shared/data/mars/megt90n000cb.lbl"
planet=mars
levels=12
configs="1x1 1x2 2x1"
keep=""
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --dem) dem=$2; shift 2 ;;
    --planet) planet=$2; shift 2 ;;
    --levels) levels=$2; shift 2 ;;
    --configs) configs=$2; shift 2 ;;
    --keep) keep=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) echo "mpi_build.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
[ -x "$pbdam" ] || { echo "mpi_build.sh: build the release preset first ($pbdam)" >&2; exit 2; }
[ -f "$dem" ] || { echo "mpi_build.sh: no DEM at $dem (use --dem)" >&2; exit 2; }
command -v mpirun >/dev/null || { echo "mpi_build.sh: mpirun not found (openmpi-bin)" >&2; exit 2; }
asroot=()
[ "$(id -u)" -eq 0 ] && asroot=(--allow-run-as-root)

work=${keep:-$(mktemp -d)}
mkdir -p "$work"
[ -n "$keep" ] || trap 'rm -rf "$work"' EXIT

echo "dem $dem, --planet $planet --levels $levels ${extra[*]:-}; $(nproc) cores; $(date -u +%FT%TZ)"
printf '%-6s %8s %11s %10s %7s %7s %7s %6s  %s\n' config wall_s lattice_M/s source_M/s effic. cpu_s work_e load1 \
  "peak RSS per rank (MB)"
declare -A wall cpu
first=""
for config in $configs; do
  ranks=${config%x*}
  threads=${config#*x}
  out="$work/out-$config"
  rm -rf "$out"
  start=$(date +%s.%N)
  # Each rank runs under /usr/bin/time so that its own peak RSS is recorded.
  mpirun "${asroot[@]}" --oversubscribe --bind-to none -np "$ranks" \
    sh -c 'exec /usr/bin/time -f "%M %U %S" -o "$0.$OMPI_COMM_WORLD_RANK" "$@"' "$work/rss-$config" \
    "$pbdam" build --dem "$dem" --planet "$planet" --levels "$levels" --threads "$threads" \
    --out "$out" --quiet "${extra[@]}" >"$work/summary-$config.txt"
  end=$(date +%s.%N)
  wall[$config]=$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')
  lattice=$(awk '/^  input/ { print $6 }' "$work/summary-$config.txt")
  source=$(awk '/^  input/ { print $2 }' "$work/summary-$config.txt")
  load=$(cut -d' ' -f1 /proc/loadavg)
  rss=""
  cpu[$config]=0
  for ((r = 0; r < ranks; r++)); do
    rss+="$(awk '{ printf "%.0f", $1 / 1024 }' "$work/rss-$config.$r") "
    cpu[$config]=$(awk -v c="${cpu[$config]}" '{ print c + $2 + $3 }' "$work/rss-$config.$r")
  done
  effic="-"
  worke="-"
  if [ -n "${wall[1x1]:-}" ]; then
    effic=$(awk -v t1="${wall[1x1]}" -v t="${wall[$config]}" -v p=$((ranks * threads)) \
      'BEGIN { printf "%.2f", t1 / (p * t) }')
    worke=$(awk -v c1="${cpu[1x1]}" -v c="${cpu[$config]}" 'BEGIN { printf "%.2f", c1 / c }')
  fi
  awk -v c="$config" -v w="${wall[$config]}" -v l="$lattice" -v s="$source" -v e="$effic" \
    -v u="${cpu[$config]}" -v we="$worke" -v ld="$load" -v r="$rss" \
    'BEGIN { printf "%-6s %8.1f %11.3f %10.3f %7s %7.1f %7s %6s  %s\n", c, w, l / w / 1e6,
             s / w / 1e6, e, u, we, ld, r }'
  if [ -z "$first" ]; then
    first=$config
  else
    same=yes
    for f in "$work/out-$first"/*; do
      cmp -s "$f" "$out/$(basename "$f")" || same=no
    done
    [ "$same" = yes ] || echo "  !! $config output differs from $first"
  fi
done
summary="$work/summary-$first.txt"
awk '/^  (lattice|input|patches|geometry|dataset)/' "$summary"
awk '/^  geometry/ { c = $2; r = $6 } /^  dataset/ { d = $2 }
     END { printf "output: %.1f MB on disk; %.1f MB with uncompressed patches (compression %.2f)\n",
                  d, d - c + r, d / (d - c + r) }' "$summary"
echo "all configurations byte-identical: $( (for c in $configs; do [ "$c" = "$first" ] && continue
  for f in "$work/out-$first"/*; do cmp -s "$f" "$work/out-$c/$(basename "$f")" || echo no; done
done) | grep -q no && echo no || echo yes)"

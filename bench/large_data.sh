#!/usr/bin/env bash
# The large-data streaming benchmark ([P-BDAM 2003] §6.2, Fig. 8): MOLA 4 px/deg upsampled
# with deterministic fractal detail (bench/fractal_dem.cpp) into a P-BDAM dataset of >= 2 GB on
# disk — far larger than any frame's working set — then the paper-like Mars flight
# (bench/paths/mars_flight.csv, 58 s) replayed cold, in paging mode, with prefetch off and on,
# side by side in one run; then the same flight in no-stall mode. Writes the reports under
# OUTDIR/report-paging and OUTDIR/report-no-stall and prints their summaries.
#   bench/large_data.sh [OUTDIR]          (default: build/large)
# Environment: PBDAM_DATA_DIR (default ../shared/data), LARGE_WIDTH (fractal DEM columns,
# default 16384: a 4096-cell lattice), LARGE_MIN_PATCH_TRIANGLES (default 512; formerly the patch vertex count, 800 the paper's ratio of
# interior to leaf patch size), LARGE_THREADS (build threads per rank, default all cores),
# LARGE_LEVELS (bintree depth, default auto: 18 makes the paper's 16384-cell lattice from any
# DEM), LARGE_RANKS (MPI ranks through mpirun, each under /usr/bin/time; default 1: no mpirun),
# LARGE_BUILD_ONLY=1 (build or reuse the dataset, print its directory on the last line, fly
# nothing: bench/larger_than_memory.sh).
# The build is out of core (docs/builder.md "Patches"): its peak RSS per rank is the DEM plus
# well under a gigabyte, whatever the lattice size.
# The DEM and the dataset are kept and reused when their parameters did not change.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/setup.sh" release >/dev/null
bin="$root/build/release"
pbdam="$bin/tools/pbdam"
data=${PBDAM_DATA_DIR:-"$root/../shared/data"}
mola="$data/mars/megt90n000cb.lbl"
[ -f "$mola" ] || { echo "large_data.sh: $mola not found (set PBDAM_DATA_DIR)" >&2; exit 2; }
out=${1:-"$root/build/large"}
width=${LARGE_WIDTH:-16384}
pv=${LARGE_MIN_PATCH_TRIANGLES:-512}
threads=${LARGE_THREADS:-0}
levels=${LARGE_LEVELS:-auto}
ranks=${LARGE_RANKS:-1}
mkdir -p "$out"

dem="$out/mola_fractal_${width}.tif"
if [ ! -f "$dem" ]; then
  "$bin/bench/pbdam_fractal_dem" --dem "$mola" --out "$dem" --width "$width" --seed 1
fi
dataset="$out/mars_${width}_pv${pv}"
[ "$levels" = auto ] || dataset="${dataset}_l${levels}"
if [ ! -f "$dataset/manifest.json" ]; then
  if [ "$ranks" -gt 1 ]; then
    asroot=()
    [ "$(id -u)" -eq 0 ] && asroot=(--allow-run-as-root)
    mpirun "${asroot[@]}" --oversubscribe --bind-to none -np "$ranks" \
      sh -c 'exec /usr/bin/time -v -o "$0.$OMPI_COMM_WORLD_RANK" "$@"' "$out/build-time.txt" \
      "$pbdam" build --dem "$dem" --planet mars --min-patch-triangles "$pv" --levels "$levels" \
      --threads "$threads" --out "$dataset" --force
  else
    /usr/bin/time -v "$pbdam" build --dem "$dem" --planet mars --min-patch-triangles "$pv" \
      --levels "$levels" --threads "$threads" --out "$dataset" --force \
      2> >(tee "$out/build-time.txt" >&2)
  fi
fi
"$pbdam" info "$dataset"
bytes=$(du -sb "$dataset" | cut -f1)
echo "dataset: $dataset, $((bytes / 1048576)) MB on disk"
if [ "$bytes" -lt 2000000000 ]; then
  echo "large_data.sh: warning: the dataset is under 2 GB (raise LARGE_WIDTH)" >&2
fi
if [ "${LARGE_BUILD_ONLY:-0}" = 1 ]; then
  echo "$dataset"
  exit 0
fi
echo
"$pbdam" bench "$dataset" --path "$root/bench/paths/mars_flight.csv" --out "$out/report-paging" \
  --cold --prefetch both --mode paging --quiet
echo
"$pbdam" bench "$dataset" --path "$root/bench/paths/mars_flight.csv" \
  --out "$out/report-no-stall" --cold --prefetch on --mode no-stall --quiet
echo
echo "reports: $out/report-paging/report.png, $out/report-no-stall/report.png"

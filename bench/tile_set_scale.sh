#!/usr/bin/env bash
# A tile set's memory and query cost against its tile count (docs/performance.md "Survey
# tiles"). ETOPO5 over the Himalaya and Tibet with fractal detail down to 3″ (bench/fractal_dem:
# no real 3″ DEM is at hand), cut into 1° tiles of 1200 × 1200 samples as SRTM3 comes (abutting),
# in sets of 1, 4, 16 and 64 tiles; each set is read as `pbdam build` reads an inset
# (bench/tile_set_scale.cpp), out of core, then the 16-tile set in memory for the comparison.
#   bench/tile_set_scale.sh [OUTDIR] [MAXSIDE]
#     OUTDIR   default build/tile-set-scale (kept); OUTDIR/scale.json holds one line a set
#     MAXSIDE  tiles along a side of the largest set, default 8 (64 tiles, 92 M samples)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-"$root/build/tile-set-scale"}
max=${2:-8}
bin="$root/build/release/bench"
etopo5=/usr/share/ferret-vis/data/etopo5.cdf
south=27 west=80
mkdir -p "$out/scratch"
source="$out/fractal.tif"
if [[ ! -f "$source" ]]; then
  "$bin/pbdam_fractal_dem" --dem "$etopo5" --out "$source" --width $((1200 * max)) \
    --bounds "$south,$west,$((south + max)),$((west + max))" --seed 3 --wgs84
fi
rm -f "$out/scale.json"
side=1
while ((side <= max)); do
  set_dir="$out/tiles-$((side * side))"
  if [[ ! -d "$set_dir" ]]; then
    mkdir -p "$set_dir.part"
    for ((r = 0; r < side; ++r)); do
      for ((c = 0; c < side; ++c)); do
        gdal_translate -q -srcwin $((c * 1200)) $((r * 1200)) 1200 1200 "$source" \
          "$set_dir.part/N$((south + max - 1 - r))E$((west + c)).tif"
      done
    done
    mv "$set_dir.part" "$set_dir"
  fi
  "$bin/pbdam_tile_set_scale" "$set_dir" "$etopo5" "$out/scratch" | tee -a "$out/scale.json"
  side=$((side * 2))
done
"$bin/pbdam_tile_set_scale" "$out/tiles-16" "$etopo5" "$out/scratch" --in-memory |
  tee -a "$out/scale.json"
echo
jq -r '[.tiles, .samples, (if .out_of_core then "mapped" else "memory" end), .read_cpu_s,
        .read_peak_rss_mib, .height_query_ns] | @tsv' "$out/scale.json" |
  awk 'BEGIN { printf "%6s %12s %7s %10s %14s %12s\n", "tiles", "samples", "held", "read CPU s",
               "peak RSS MiB", "query ns" }
       { printf "%6d %12d %7s %10.1f %14.0f %12.0f\n", $1, $2, $3, $4, $5, $6 }'

#!/usr/bin/env bash
# Survey tiles as they come (docs/performance.md "Survey tiles"): runs pbdam_survey_tiles
# (a real DEM — ETOPO5 over the Himalaya and Tibet — with voids punched on its steepest slopes,
# joined to ETOPO20, against the truth and gdal_fillnodata.py -md 100; the same DEM cut into
# 2 x 2 tiles given as four files, a directory and a VRT, against the single file), then renders
# each tiled dataset looking obliquely along both seams from 2 km above the ground with a
# magenta background and counts the hole pixels (bench/magenta_holes.py).
#   bench/survey_tiles.sh [OUTDIR] [PBDAM]
#     OUTDIR  default build/survey-tiles (kept); OUTDIR/survey.json holds the figures
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-"$root/build/survey-tiles"}
pbdam=${2:-"$root/build/release/tools/pbdam"}
tool="$(dirname "$pbdam")/../bench/pbdam_survey_tiles"
mkdir -p "$out"
"$tool" "$out" --json "$out/survey.json"

seam_lat=$(jq -r .seam_lat_deg "$out/survey.json")
seam_lon=$(jq -r .seam_lon_deg "$out/survey.json")
ground() {  # dataset lat lon: the rendered height there
  "$pbdam" height "$1" --at "$2,$3" --json | jq -r .height_m
}
frames=()
for dataset in files dir vrt; do
  # Along the east-west seam, heading east; along the north-south seam, heading north.
  for view in "$seam_lat $(awk -v x="$seam_lon" 'BEGIN { print x - 6 }') 90" \
              "$(awk -v x="$seam_lat" 'BEGIN { print x - 3 }') $seam_lon 0"; do
    read -r lat lon heading <<<"$view"
    alt=$(awk -v g="$(ground "$out/$dataset" "$lat" "$lon")" 'BEGIN { print g + 2000 }')
    frame="$out/seam-$dataset-$heading.png"
    "$pbdam" render "$out/$dataset" --camera "$lat,$lon,$alt,$heading,-12,0" --width 640 \
      --height 360 --clear 255,0,255 --out "$frame" >/dev/null
    frames+=("$frame")
  done
done
echo
python3 "$root/bench/magenta_holes.py" "${frames[@]}"

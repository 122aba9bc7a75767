#!/usr/bin/env bash
# The main job on the built-in default data (README command 1): set up and build, inspect the
# Debian-packaged ETOPO5 Earth model, build a P-BDAM dataset from it textured with the xplanet
# Earth image, verify it against the DEM and print its summary, then fly over the Himalayas:
# write the camera path, replay it as a cold-cache benchmark with and without prefetch, and
# render it under a morning sun with the atmosphere to numbered PNGs and an H.264 MP4 (Debian's
# ffmpeg, which scripts/setup.sh installs).
# It needs only what scripts/setup.sh installs from Debian: no npm, no network beyond apt.
#   scripts/demo.sh [OUTDIR]     (default: build/demo/earth)
# The demo lattice is 1024 cells per face side (bintree depth 10, about 10 km a cell: ETOPO5's own
# 9 km), built in about 30 s on 2 cores; `--levels auto` builds ETOPO5 at its full density (2048
# cells, depth 12), which takes about a minute.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/setup.sh" release >/dev/null
pbdam="$root/build/release/tools/pbdam"
etopo5=/usr/share/ferret-vis/data/etopo5.cdf
earth=/usr/share/xplanet/images/earth.jpg
out=${1:-"$root/build/demo/earth"}
"$pbdam" dem info "$etopo5" --at 27.988,86.925
echo
"$pbdam" build --dem "$etopo5" --texture "$earth" --planet earth --levels 10 --out "$out" --force
echo
"$pbdam" verify "$out" --dem "$etopo5" --quiet
echo
"$pbdam" info "$out"
echo
flight="$out/flight.csv"
# From 3,000 km over the Indian Ocean to 150 km over the Ganges plain, looking 25° down towards
# the Himalayas: the flight ends where the data still has detail, the range in perspective.
"$pbdam" path great-circle --from 12,80,3000e3 --to 25,86,150e3 --duration 6 --fps 12 \
  --pitch-deg -25 --dataset "$out" --out "$flight"
"$pbdam" bench "$out" --path "$flight" --out "$out/bench" --cold --width 640 --height 360 --quiet
echo
mkdir -p "$out/frames"
# Under the sun of a June morning (07:10 local time, its light low from the east over the
# Himalayas) with Earth's atmosphere: the limb, haze with distance, and the relief in long light.
"$pbdam" render "$out" --path "$flight" --out "$out/frames/himalaya" --width 640 --height 360 \
  --time 2024-06-20T01:30:00Z --stats "$out/frames/stats.jsonl" --quiet
echo "frames: $out/frames/himalaya_*.png (per-frame statistics in $out/frames/stats.jsonl)"
video="$out/frames/himalaya.mp4"
if [ ! -s "$video" ]; then
  echo "demo: $video was not written (is ffmpeg installed? scripts/setup.sh installs it)" >&2
  exit 1
fi
echo "video:  $video"

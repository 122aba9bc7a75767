#!/usr/bin/env bash
# The README's sunrise: a 10 s descent from 500 km over the east end of Valles Marineris (Coprates
# Chasma) west along the canyon to 50 km over Melas Chasma, while the sun rises over it: the
# path's time runs 1,080 times faster than the flight from a Mars night (2024-01-01 18:45 UTC,
# Mars24) to mid-morning over Melas. Made by `pbdam path great-circle` and `pbdam render --path …
# --time … --time-scale …` with Mars's atmosphere (on by default under a real sun), on MOLA at
# 4 px/deg (its 512-cell test build: the canyon's walls are a few samples across).
#   scripts/sunrise_valles.sh [DATASET] [OUT]
# Defaults: build/testdata/mola (tests/support/build_test_datasets.sh makes it) and
# docs/images/valles_sunrise (writes OUT.mp4, and OUT.png: frames 0, 5, 8 and 10 s at half size,
# the video's poster; the frames go to a scratch folder).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
pbdam=${PBDAM:-$root/build/release/tools/pbdam}
dataset=${1:-$root/build/testdata/mola}
out=${2:-$root/docs/images/valles_sunrise}
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
"$pbdam" path great-circle --from -13,-50,500e3 --to -8,-73,50e3 --duration 10 --fps 30 \
  --dataset "$dataset" --pitch-deg -25 --out "$scratch/path.csv"
"$pbdam" render "$dataset" --path "$scratch/path.csv" --out "$scratch/valles" --width 640 \
  --height 360 --time 2024-01-01T18:45:00Z --time-scale 1080 --quiet
mkdir -p "$(dirname "$out")"
cp "$scratch/valles.mp4" "$out.mp4"
ffmpeg -loglevel error -y -i "$out.mp4" \
  -vf "select='eq(n\,0)+eq(n\,150)+eq(n\,240)+eq(n\,300)',scale=320:180,tile=2x2" \
  -frames:v 1 "$out.png"
echo "wrote $out.mp4 and $out.png"

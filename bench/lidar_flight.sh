#!/usr/bin/env bash
# The lidar-class flight: from orbit down to 50 m above a 1 m inset (the dataset of
# docs/performance.md, "Finer than 2^15 cells a face"), flown cold with prefetch on (`pbdam bench`
# at WIDTHxHEIGHT, paging mode), and the same path over the base alone (ETOPO5 with the same
# levels and leaves, built here when missing) for the render thread's page faults; then every
# EVERY-th pose of the path rendered in exact mode with a magenta clear colour and searched for
# holes (bench/magenta_holes.py: magenta below the terrain's top in a column).
#   bench/lidar_flight.sh [OUTDIR]      (default build/lidar-flight)
# Environment: LIDAR_DATASET (default build/srtm/lidar), BASE_DATASET (default build/srtm/etopo5),
# AT (LAT,LON of the end of the flight, inside the inset; default 49.84,5.89), WIDTH (1280),
# HEIGHT (720), EVERY (30), FLIGHT_SECONDS (40).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-"$root/build/lidar-flight"}
pbdam="$root/build/release/tools/pbdam"
lidar=${LIDAR_DATASET:-"$root/build/srtm/lidar"}
base=${BASE_DATASET:-"$root/build/srtm/etopo5"}
at=${AT:-49.84,5.89}
width=${WIDTH:-1280}
height=${HEIGHT:-720}
every=${EVERY:-30}
seconds=${FLIGHT_SECONDS:-40}
if [ ! -f "$lidar/manifest.json" ]; then
  echo "lidar_flight: $lidar is not a dataset (build it as docs/performance.md says under" \
       "'Finer than 2^15 cells a face', or set LIDAR_DATASET)" >&2
  exit 2
fi
mkdir -p "$out"
if [ ! -f "$base/manifest.json" ]; then
  echo "building the base alone into $base"
  "$pbdam" build --dem /usr/share/ferret-vis/data/etopo5.cdf --planet earth --levels 8 \
    --leaf-vertices 17 --out "$base" --force --quiet
fi

# The path: from orbit (3,000 km, 1,300 km away) to 3 km over the inset's edge in the first 60%
# of the time, then an approach down to 50 m above AT (above the rendered terrain there, as
# `pbdam height` gives it) in the rest: two great-circle legs, each with its eased altitude.
ground=$("$pbdam" height "$lidar" --at "$at" --json |
         python3 -c 'import json, sys; print(json.load(sys.stdin)["height_m"])')
lat=${at%,*}
lon=${at#*,}
edge=$(python3 -c "print(f'{$lat - 0.012:.6f},{$lon - 0.018:.6f}')")
orbit=$(python3 -c "print(f'{$lat - 8:.6f},{$lon - 10:.6f}')")
end=$(python3 -c "print(f'{$ground + 50:.3f}')")
first=$(python3 -c "print($seconds * 0.6)")
"$pbdam" path great-circle --dataset "$lidar" --from "$orbit,3000000" --to "$edge,3000" \
  --duration "$first" --out "$out/path-1.csv" > /dev/null
"$pbdam" path great-circle --dataset "$lidar" --from "$edge,3000" --to "$at,$end" \
  --duration "$(python3 -c "print($seconds - $first)")" --out "$out/path-2.csv" > /dev/null
python3 - "$out" "$first" <<'PY'
import sys
out, first = sys.argv[1], float(sys.argv[2])
one = open(f"{out}/path-1.csv").read().splitlines()
two = open(f"{out}/path-2.csv").read().splitlines()[2:]  # its header and first pose (= one's last)
rows = [f"{float(r.split(',', 1)[0]) + first!r},{r.split(',', 1)[1]}" for r in two]
open(f"{out}/path.csv", "w").write("\n".join(one + rows) + "\n")
PY
echo "path: $out/path.csv ($(($(wc -l < "$out/path.csv") - 1)) poses over $seconds s, ends 50 m above $ground m at $at)"

for name in lidar base; do
  dataset=$([ "$name" = lidar ] && echo "$lidar" || echo "$base")
  rm -rf "$out/$name"
  /usr/bin/time -f "%M" -o "$out/$name.rss" "$pbdam" bench "$dataset" --path "$out/path.csv" \
    --out "$out/$name" --cold --prefetch on --width "$width" --height "$height" --quiet \
    > "$out/$name.log" 2>&1
done
python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
runs = {n: json.load(open(f"{out}/{n}/summary.json"))["runs"][0] for n in ("lidar", "base")}
for n, r in runs.items():
    print(f"{n}: {r['fps_mean']:.1f} fps, p99 {r['frame_ms_p99']:.1f} ms, "
          f"{r['triangles_per_frame_mean']:,.0f} triangles a frame, render-thread faults "
          f"{r['render_thread_major_faults']} ({r['render_thread_major_faults_after_first_frame']} "
          f"after the first frame), data stalls {r['data_stalls']}")
a = runs["lidar"]["render_thread_major_faults_after_first_frame"]
b = runs["base"]["render_thread_major_faults_after_first_frame"]
print(f"faults after the first frame, lidar / base alone: {a} / {b}"
      + (f" = {a / b:.2f}" if b else ""))
PY

# Holes: every EVERY-th pose in exact mode, magenta behind the terrain.
awk -v every="$every" 'NR == 1 || (NR - 2) % every == 0' "$out/path.csv" > "$out/holes-path.csv"
rm -rf "$out/frames" && mkdir -p "$out/frames"
"$pbdam" render "$lidar" --path "$out/holes-path.csv" --out "$out/frames/f" --clear 255,0,255 \
  --width "$width" --height "$height" --quiet > "$out/render.log" 2>&1
rm -f "$out/frames/f.mp4"
if "$root/bench/magenta_holes.py" "$out"/frames/f_*.png > "$out/holes.txt"; then
  echo "holes: none in $(ls "$out"/frames/f_*.png | wc -l) frames along the path"
else
  echo "holes: $(grep -c -v ': 0 hole pixels' "$out/holes.txt" || true) frames with holes (see $out/holes.txt)"
fi

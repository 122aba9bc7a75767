#!/usr/bin/env bash
# The acceptance of the terrain queries on real datasets.
# 1. A focus cut on the large-data dataset: 20 km around 18.65N 226.2E at full detail, 8 px
#    elsewhere. Printed: the focus-only cut's mesh (closed: V = F/2 + 2) and the level of every
#    patch the circle reaches (the leaves' level), for the focus alone and with a camera; then
#    frames drawn over a magenta background looking straight down at the circle from three
#    cameras, and how many magenta pixels (holes) each shows.
# 2. pbdam query viewshed over real datasets, each checked by the brute-force ray march over its
#    source DEM (--check-dem), printing one row per observer: cells, visible fraction, the
#    agreement over all cells and over the cells either sees, and the time (extraction,
#    projection, the device passes; the ray march is not counted).
#   - Mars: the large-data dataset (bench/large_data.sh builds it: MOLA with fractal detail,
#     4096-cell lattice, > 2 GB), 500 km from the Olympus Mons summit and elsewhere.
#   - Earth: ETOPO5 at full density (--levels auto: a 2048-cell lattice, 4.9 km) and at twice
#     that (--levels 14, 2.4 km), 200 km around points in the Alps; built here when missing.
#   bench/terrain_queries.sh [LARGE_DIR] [OUTDIR]
#     LARGE_DIR  the large-data output directory (default build/large: its mars_16384_pv512
#                dataset and mola_fractal_16384.tif; the Mars rows are skipped without them)
#     OUTDIR     where the ETOPO5 datasets, meshes, frames and masks go (default build/viewshed)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/setup.sh" release >/dev/null
pbdam="$root/build/release/tools/pbdam"
large=${1:-"$root/build/large"}
out=${2:-"$root/build/viewshed"}
etopo=/usr/share/ferret-vis/data/etopo5.cdf
mkdir -p "$out"

row() {  # NAME DATASET DEM AT RADIUS
  local name=$1 dataset=$2 dem=$3 at=$4 radius=$5
  "$pbdam" query viewshed "$dataset" --at "$at" --radius-m "$radius" \
      --out "$out/$name.tif" --check-dem "$dem" --json > "$out/$name.json"
  python3 - "$name" "$at" "$out/$name.json" <<'PY'
import json, sys
name, at, path = sys.argv[1:]
j = json.load(open(path)); c = j["check"]
print(f"| {name} | {at} | {j['radius_m']/1000:.0f} km, {j['cells']}² cells of {j['cell_m']:.0f} m "
      f"| {100*j['visible_fraction']:.2f}% | {100*c['agreement']:.2f}% | "
      f"{100*c['visible_agreement']:.1f}% ({c['visible_only_on_terrain']} / {c['visible_only_on_dem']}) "
      f"| {j['total_ms']:.0f} ms ({j['extract_ms']:.0f} + {j['project_ms']:.0f} + {j['device_ms']:.0f}) |")
PY
}

mars="$large/mars_16384_pv512"
fractal="$large/mola_fractal_16384.tif"
if [ -f "$mars/manifest.json" ]; then
  echo "focus cut, 20 km around 18.65N 226.2E at full detail:"
  "$pbdam" query cut "$mars" --focus 18.65,226.2,20000 --out "$out/focus.ply" \
      --json > "$out/focus.json"
  python3 - "$out/focus.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); f = j["in_focus"]
closed = j["vertices"] == j["triangles"] // 2 + 2
print(f"  focus alone: {j['patches']} patches, V = {j['vertices']}, F/2 + 2 = "
      f"{j['triangles'] // 2 + 2}: {'closed' if closed else 'NOT CLOSED'}; {f['patches']} patches "
      f"in the circle, levels {f['min_level']}-{f['max_level']} (leaves: {f['leaf_level']})")
PY
  for cam in 18.65,226.2,150e3,0,-90,0 18.65,226.2,40e3,0,-90,0 18.5,226.3,30e3,45,-90,0; do
    "$pbdam" query cut "$mars" --camera "$cam" --tolerance-px 8 --focus 18.65,226.2,20000 \
        --out "$out/focus_cam.ply" --json > "$out/focus_cam.json"
    python3 - "$out/focus_cam.json" "$cam" <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); f = j["in_focus"]
print(f"  camera {sys.argv[2]}, 8 px: {j['patches']} patches, levels {j['min_level']}-"
      f"{j['max_level']}; in the circle {f['patches']}, levels {f['min_level']}-{f['max_level']}")
PY
    "$pbdam" render "$mars" --camera "$cam" --tolerance-px 8 --focus 18.65,226.2,20000 \
        --clear 255,0,255 --out "$out/focus_$cam.png" --quiet
    python3 - "$out/focus_$cam.png" <<'PY'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
i, idat = 8, b""
while i < len(data):
    n = struct.unpack(">I", data[i:i + 4])[0]; kind = data[i + 4:i + 8]; body = data[i + 8:i + 8 + n]
    i += 12 + n
    if kind == b"IHDR": w, h, _, colour = struct.unpack(">IIBB", body[:10]); bpp = {2: 3, 6: 4}[colour]
    elif kind == b"IDAT": idat += body
raw = zlib.decompress(idat); stride = w * bpp; prev = bytearray(stride); p = 0; holes = 0
for y in range(h):
    f = raw[p]; line = bytearray(raw[p + 1:p + 1 + stride]); p += 1 + stride
    for x in range(stride):
        a = line[x - bpp] if x >= bpp else 0; b = prev[x]; c = prev[x - bpp] if x >= bpp else 0
        if f == 1: line[x] = (line[x] + a) & 255
        elif f == 2: line[x] = (line[x] + b) & 255
        elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
        elif f == 4:
            pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
            line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    holes += sum(1 for k in range(0, stride, bpp) if line[k] == 255 and line[k + 1] == 0 and line[k + 2] == 255)
    prev = line
print(f"    frame {w}x{h}: {holes} magenta pixels (holes)")
PY
  done
  echo
fi

echo "| dataset | observer (lat, lon, m above ground) | grid | visible | agree (all cells) | agree (cells either sees; only on leaves / only on DEM) | time (extract + project + device) |"
echo "|---|---|---|---|---|---|---|"
if [ -f "$mars/manifest.json" ] && [ -f "$fractal" ]; then
  row mars-olympus-10m "$mars" "$fractal" 18.65,226.2,10 500000
  row mars-olympus-1km "$mars" "$fractal" 18.65,226.2,1000 500000
  row mars-tharsis-2km "$mars" "$fractal" 10,200,2000 500000
else
  echo "terrain_queries.sh: $mars or $fractal missing (run bench/large_data.sh): Mars rows skipped" >&2
fi
for levels in auto 14; do
  dataset="$out/etopo5_$levels"
  if [ ! -f "$dataset/manifest.json" ]; then
    "$pbdam" build --dem "$etopo" --planet earth --levels "$levels" --out "$dataset" --force \
        --quiet
  fi
  row "etopo5-$levels-montblanc-10m" "$dataset" "$etopo" 45.83,6.86,10 200000
  row "etopo5-$levels-valais-10m" "$dataset" "$etopo" 46.0,7.5,10 200000
  row "etopo5-$levels-zermatt-100m" "$dataset" "$etopo" 45.97,7.66,100 200000
  row "etopo5-$levels-alps-2km" "$dataset" "$etopo" 46.5,8.0,2000 200000
done

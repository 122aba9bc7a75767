#!/usr/bin/env bash
# The main job on the built-in default data (README command 1): set up and build, inspect the
# Debian-packaged ETOPO5 Earth model, build a P-BDAM dataset from it textured with the xplanet
# Earth image, verify it against the DEM and print its summary.
#   scripts/demo.sh [OUTDIR]     (default: build/demo/earth)
# The demo lattice is 512 cells per face side (bintree depth 8); `--levels auto` builds ETOPO5
# at its full density (2048 cells, depth 12), which takes several minutes on 2 cores.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/setup.sh" release >/dev/null
pbdam="$root/build/release/tools/pbdam"
etopo5=/usr/share/ferret-vis/data/etopo5.cdf
earth=/usr/share/xplanet/images/earth.jpg
out=${1:-"$root/build/demo/earth"}
"$pbdam" dem info "$etopo5" --at 27.988,86.925
echo
"$pbdam" build --dem "$etopo5" --texture "$earth" --planet earth --levels 8 --out "$out" --force
echo
"$pbdam" verify "$out" --dem "$etopo5" --quiet
echo
"$pbdam" info "$out"

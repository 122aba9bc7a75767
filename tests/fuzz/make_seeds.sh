#!/usr/bin/env bash
# Rewrites the fuzz seeds that are outputs of `pbdam build` — face files, a manifest and the
# checkpoint's files — with the given pbdam, after a change of the dataset format or of the
# checkpoint's files. The other seeds (patch blobs, tiles, camera paths, serve queries, greedy
# insertion inputs, and inputs found by fuzzing) are not build outputs and stay as they are.
#   tests/fuzz/make_seeds.sh [PBDAM]      (default build/release/tools/pbdam)
# Environment: PBDAM_DATA_DIR (default ../shared/data; the MOLA file is needed).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
pbdam=${1:-"$root/build/release/tools/pbdam"}
data=${PBDAM_DATA_DIR:-"$root/../shared/data"}
mola="$data/mars/megt90n000cb.lbl"
[ -x "$pbdam" ] || { echo "make_seeds.sh: $pbdam is not executable" >&2; exit 2; }
[ -f "$mola" ] || { echo "make_seeds.sh: $mola not found (set PBDAM_DATA_DIR)" >&2; exit 2; }
corpus="$root/tests/fuzz/corpus"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Face files: a depth-0 build of an 8 × 4 int16le global grid of 1000·sin(0.7·i) + 500·cos(1.3·j).
python3 - "$work/grid.raw" <<'EOF'
import math, struct, sys
with open(sys.argv[1], "wb") as f:
    for j in range(4):
        for i in range(8):
            f.write(struct.pack("<h", int(round(1000 * math.sin(0.7 * i) + 500 * math.cos(1.3 * j)))))
EOF
"$pbdam" build --dem "$work/grid.raw" --raw-size 8,4 --raw-type int16le --bounds -90,-180,90,180 \
  --planet mars --levels 0 --leaf-vertices 3 --texture-tile 16 --texture-format rgba8 \
  --out "$work/tiny" --quiet
cp "$work/tiny/face0.pbdam" "$corpus/face_file/mars_face0.bin"
cp "$work/tiny/face4.pbdam" "$corpus/face_file/mars_face4.bin"
# And a sparse forest: leaves of level 6 over a small box on face 0, shallower elsewhere.
"$pbdam" build --dem "$work/grid.raw" --raw-size 8,4 --raw-type int16le --bounds -90,-180,90,180 \
  --planet mars --levels 0 --deep-region -2,-36,2,-32@6 --leaf-vertices 3 --texture-tile 16 \
  --texture-format rgba8 --out "$work/sparse" --quiet
cp "$work/sparse/face0.pbdam" "$corpus/face_file/mars_sparse_face0.bin"

# And an inset: an 8 × 8 ASCII grid at 4° (with its WGS 84 .prj) joined to that grid on Earth:
# leaves carry their sources, the manifest lists the inset.
python3 - "$work/inset.asc" <<'EOF'
import math, sys
with open(sys.argv[1], "w") as f:
    f.write("ncols 8\nnrows 8\nxllcorner 20\nyllcorner 10\ncellsize 4\nNODATA_value -9999\n")
    for j in range(8):
        f.write(" ".join(str(int(round(800 * math.sin(0.9 * i) * math.cos(0.5 * j)))) for i in range(8)) + "\n")
with open(sys.argv[1][:-4] + ".prj", "w") as f:
    f.write('GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],'
            'PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]]')
EOF
"$pbdam" build --dem "$work/grid.raw" --raw-size 8,4 --raw-type int16le --bounds -90,-180,90,180 \
  --planet earth --levels 0 --inset "$work/inset.asc" --leaf-vertices 3 --texture-tile 16 \
  --texture-format rgba8 --out "$work/inset" --quiet
cp "$work/inset/face0.pbdam" "$corpus/face_file/earth_inset_face0.bin"
cp "$work/inset/manifest.json" "$corpus/manifest/earth_inset.json"

# A manifest: MOLA at two levels with BC1 tiles.
"$pbdam" build --dem "$mola" --planet mars --levels 2 --leaf-vertices 9 --min-patch-triangles 16 \
  --texture-tile 16 --out "$work/levels2" --quiet
cp "$work/levels2/manifest.json" "$corpus/manifest/mars_levels2.json"

# The checkpoint: the same build with RGBA8 tiles stopped before its manifest, and again before
# level 0 for a carry file; each file prefixed with fuzz_checkpoint's selector byte.
small=(--dem "$mola" --planet mars --levels 2 --leaf-vertices 9 --min-patch-triangles 16
       --texture-tile 16 --texture-format rgba8)
PBDAM_TEST_FAIL_WRITE=manifest "$pbdam" build "${small[@]}" --out "$work/ckp" --quiet \
  >/dev/null 2>&1 || true
PBDAM_TEST_FAIL_RANK=0 PBDAM_TEST_FAIL_LEVEL=0 PBDAM_TEST_FAIL_MODE=error \
  "$pbdam" build "${small[@]}" --out "$work/carry" --quiet >/dev/null 2>&1 || true
ckp="$work/ckp/.build-checkpoint"
for f in "$ckp/state" "$ckp/level-00.part-0.nodes" "$work/carry/.build-checkpoint/level-01.part-0.carry" \
         "$ckp/texture.part-0.tiles"; do
  [ -f "$f" ] || { echo "make_seeds.sh: the stopped build left no $f" >&2; exit 1; }
done
seed() { { printf "\\x$1"; cat "$2"; } >"$corpus/checkpoint/$3"; }
seed 00 "$ckp/state" state.txt
seed 01 "$ckp/level-00.part-0.nodes" level-00.nodes
seed 02 "$work/carry/.build-checkpoint/level-01.part-0.carry" level-01.carry
seed 03 "$ckp/texture.part-0.tiles" texture-rgba8.tiles
echo "seeds rewritten in $corpus (face_file, manifest, checkpoint)"

#!/usr/bin/env bash
# The installed package as another program sees it: `cmake --install` of this build into a scratch
# prefix, examples/headless configured and built against it with find_package(pbdam) (a fresh
# build directory, the same compiler, warnings as errors), its frame of the MOLA test dataset
# compared byte for byte with `pbdam render`'s of the same camera, and pbdam.pc resolved, its
# cflags compiling the headers and its libs linking the example again. Then examples/marker, built
# the same way, draws the terrain and a marker of its own into its own pass and depth buffer,
# looking east at Olympus Mons from 420 km west: a marker on the far flank, behind the summit,
# is hidden (the frame is `pbdam render`'s, byte for byte, and the terrain's line-of-sight query
# agrees), one out of view leaves the frame `pbdam render`'s too, and one on the near flank is
# drawn, under either depth convention.
#   install_example_test.sh BUILD_DIR SOURCE_DIR PBDAM CXX GENERATOR DATASET ARTIFACTS_DIR
# Exit code 77 (skipped): the dataset was not built (a failure under CI=true).
set -euo pipefail
build=$1 src=$2 pbdam=$3 cxx=$4 generator=$5 dataset=$6 artifacts=$7
camera=12,221,800e3,35,-45,0  # Olympus Mons from the south-west, 45° down
width=320 height=240
if [[ ! -f "$dataset/manifest.json" ]]; then
  echo "test dataset $dataset was not built (see the build_test_datasets test)"
  [[ "${CI:-}" == "true" ]] && exit 1
  exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
fail() { echo "FAIL: $*"; exit 1; }
step() { printf '%-44s %3d s\n' "$1" $((SECONDS - start)); }
start=$SECONDS

cmake --install "$build" --prefix "$prefix" >"$tmp/install.log" || { cat "$tmp/install.log"; fail "cmake --install"; }
for file in lib/cmake/pbdam/pbdamConfig.cmake lib/cmake/pbdam/pbdamConfigVersion.cmake \
            lib/cmake/pbdam/pbdamTargets.cmake lib/pkgconfig/pbdam.pc lib/libpbdam_oiio.so \
            include/pbdam/gpu/TerrainRenderer.h include/pbdam/formats/Result.h; do
  [[ -f "$prefix/$file" ]] || fail "the install has no $file"
done
# Nothing installed names the source or build tree, binaries included (a RUNPATH, a module path):
# an installed package must not reach back into them.
if leaks=$(grep -rlF -e "$src" -e "$(realpath "$build")" "$prefix"); then
  fail "installed files name the source or build tree: $leaks"
fi
step "installed into a scratch prefix"

cmake -S "$src/examples/headless" -B "$tmp/example" -G "$generator" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_COMPILE_WARNING_AS_ERROR=ON >"$tmp/configure.log" ||
  { cat "$tmp/configure.log"; fail "configuring the example against the installed package"; }
cmake --build "$tmp/example" >"$tmp/build.log" || { cat "$tmp/build.log"; fail "building the example"; }
step "example configured and built"

# The example's image codec must be the installed module, not the build tree's.
LD_DEBUG=files LD_DEBUG_OUTPUT="$tmp/ld" \
  "$tmp/example/pbdam_headless" "$dataset" "$camera" "$tmp/example.png" $width $height |
  tee "$tmp/example.txt"
grep -qF "file=$prefix/lib/libpbdam_oiio.so " "$tmp"/ld.* ||
  fail "libpbdam_oiio.so was not loaded from the prefix: $(grep -h 'file=.*pbdam_oiio' "$tmp"/ld.* || true)"
grep -qE ": [1-9][0-9]* patches, [1-9][0-9]* triangles" "$tmp/example.txt" || fail "no patches drawn"
"$pbdam" render "$dataset" --camera "$camera" --width $width --height $height \
  --out "$tmp/render.png" --quiet
cmp "$tmp/example.png" "$tmp/render.png" || fail "the example's frame is not pbdam render's"
# Not a flat image: every band varies (GDAL reads PNG).
bands=$(gdalinfo -stats "$tmp/example.png" | grep -c "STATISTICS_STDDEV=[1-9]" || true)
[[ $bands -eq 3 ]] || fail "the frame is flat in $((3 - bands)) of its 3 bands"
mkdir -p "$artifacts" && cp "$tmp/example.png" "$artifacts/headless.png"
step "frame is pbdam render's, byte for byte"

export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
pkg-config --cflags --libs pbdam >/dev/null || fail "pkg-config cannot resolve pbdam"
echo '#include "pbdam/gpu/TerrainRenderer.h"' |
  "$cxx" -std=c++20 -fsyntax-only $(pkg-config --cflags pbdam) -x c++ - ||
  fail "pbdam.pc's cflags do not compile the headers"
objects=$(find "$tmp/example" -name '*.o')
# shellcheck disable=SC2046  # pkg-config's words are separate arguments
"$cxx" -o "$tmp/pc_headless" $objects $(pkg-config --libs pbdam) || fail "pbdam.pc's libs do not link"
"$tmp/pc_headless" "$dataset" "$camera" "$tmp/pc.png" $width $height >/dev/null
cmp "$tmp/pc.png" "$tmp/render.png" || fail "the pkg-config link's frame is not pbdam render's"
step "pbdam.pc compiles, links and renders the same"

cmake -S "$src/examples/marker" -B "$tmp/marker" -G "$generator" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_COMPILE_WARNING_AS_ERROR=ON >"$tmp/marker-configure.log" ||
  { cat "$tmp/marker-configure.log"; fail "configuring the marker example against the installed package"; }
cmake --build "$tmp/marker" >"$tmp/marker-build.log" ||
  { cat "$tmp/marker-build.log"; fail "building the marker example"; }
marker=$tmp/marker/pbdam_marker
"$marker" "$dataset" "$camera" "$tmp/none.png" $width $height | tee "$tmp/none.txt"
cmp "$tmp/none.png" "$tmp/render.png" || fail "the marker example's frame without a marker is not pbdam render's"
eye=18.65,219,30000,90,-3,0  # 30 km up, 420 km west of the summit, looking east
"$pbdam" render "$dataset" --camera "$eye" --width $width --height $height \
  --out "$tmp/eye.png" --quiet
"$marker" "$dataset" "$eye" "$tmp/behind.png" $width $height 18.65,229.5,0 | tee "$tmp/behind.txt"
grep -qF "marker hidden (line of sight), 0 pixels drawn" "$tmp/behind.txt" ||
  fail "the marker behind the summit is not hidden"
cmp "$tmp/behind.png" "$tmp/eye.png" || fail "the frame with the hidden marker is not pbdam render's"
# Out of view (west of the eye, behind it): nothing of it drawn, the frame is render's.
"$marker" "$dataset" "$eye" "$tmp/away.png" $width $height 18.65,214,0 | tee "$tmp/away.txt"
grep -qF ", 0 pixels drawn" "$tmp/away.txt" || fail "the marker out of view was drawn"
cmp "$tmp/away.png" "$tmp/eye.png" || fail "the frame with the marker out of view is not pbdam render's"
for depth in reversed-z zero-near; do
  "$marker" "$dataset" "$eye" "$tmp/front-$depth.png" $width $height 18.65,222,0 $depth |
    tee "$tmp/front-$depth.txt"
  grep -qE "marker visible \(line of sight\), [1-9][0-9]{2,} pixels drawn" "$tmp/front-$depth.txt" ||
    fail "the marker on the near flank is not drawn ($depth)"
done
cp "$tmp/front-reversed-z.png" "$artifacts/marker.png"
step "marker hidden behind the summit, drawn in front"

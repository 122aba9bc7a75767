#!/usr/bin/env bash
# CTest fixture "datasets": builds the small real-data datasets that runtime, GPU and CLI tests
# read, once, into one directory shared by every preset (datasets are deterministic, so any
# pbdam binary gives the same bytes; the release binary is preferred because it is the fastest).
#   build_test_datasets.sh PBDAM DATA_DIR OUT_DIR [RELEASE_PBDAM]
# A dataset is rebuilt when it is missing or older than the binary that would build it.
# Missing input data: fails under CI=true, otherwise prints why and builds nothing (the tests
# that need it then skip with the same message).
# Built datasets are also kept in $PBDAM_TESTDATA_CACHE (default ~/.cache/pbdam/testdata; "off"
# keeps none), keyed by what decides their bytes: the pbdam binary's content and the shared
# libraries it loads (path, size, time), the build arguments and the input files' content. A
# clean clone on the same machine then copies them instead of building them again; the three
# most recent keys of each dataset are kept.
set -euo pipefail
pbdam=$1 data=$2 out=$3 release=${4:-}
if [[ -n "$release" && -x "$release" ]]; then pbdam=$release; fi
mkdir -p "$out"
cache=${PBDAM_TESTDATA_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/pbdam/testdata}
status=0
build() {  # name, input file, build arguments...
  local name=$1 input=$2
  shift 2
  if [[ ! -r "$input" ]]; then
    echo "test dataset '$name' not built: input $input is missing (set PBDAM_DATA_DIR)"
    [[ "${CI:-}" == "true" ]] && status=1
    return 0
  fi
  if [[ -f "$out/$name/manifest.json" && "$out/$name/manifest.json" -nt "$pbdam" ]]; then
    echo "test dataset '$name' is up to date"
    return 0
  fi
  local key="" kept=""
  if [[ "$cache" != off ]]; then
    key=$(datasetKey "$input" "$@")
    kept="$cache/$name-$key"
    if [[ -f "$kept/manifest.json" ]]; then
      echo "test dataset '$name' copied from $kept"
      rm -rf "$out/$name" && cp -r "$kept" "$out/$name"
      touch "$kept"
      return 0
    fi
  fi
  echo "building test dataset '$name' with $pbdam"
  "$pbdam" build --dem "$input" "$@" --out "$out/$name" --force --quiet
  if [[ -n "$kept" ]]; then
    mkdir -p "$cache"
    rm -rf "$kept.tmp" && cp -r "$out/$name" "$kept.tmp" && mv "$kept.tmp" "$kept"
    # Keep the three most recent keys of this dataset.
    ls -dt "$cache/$name"-* 2>/dev/null | grep -v '\.tmp$' | tail -n +4 | xargs -r rm -rf
  fi
}
# datasetKey ARGS...: the cache key of a build of `pbdam` with these arguments.
datasetKey() {
  {
    sha256sum "$pbdam"
    ldd "$pbdam" | awk '/=> \// { print $3 }' | sort | xargs -r stat -L -c '%n %s %Y'
    printf '%s\n' "$@"
    for arg in "$@"; do if [[ -f "$arg" ]]; then sha256sum "$arg"; fi; done
  } | sha256sum | cut -c1-32
}
data=${PBDAM_DATA_DIR:-$data}
build mola "$data/mars/megt90n000cb.lbl" --planet mars
build earth /usr/share/ferret-vis/data/etopo5.cdf --planet earth --levels 8
# A hybrid: ETOPO5 with the Luxembourg GeoTIFF joined to it (leaves at level 20 over it).
luxembourg="$data/geotiff/terra_elev_luxembourg.tif"
if [[ -r "$luxembourg" ]]; then
  build luxembourg /usr/share/ferret-vis/data/etopo5.cdf --planet earth --levels 6 \
    --leaf-vertices 17 --inset "$luxembourg"
  # Survey tiles: the same GeoTIFF cut into two tiles sharing a column (SRTM's convention), with
  # voids punched into each — 2 × 2 samples at 49.8542°N 5.9958°E in the west tile, one at
  # 49.7542°N 6.2625°E in the east one — given as two insets: one surface, voids filled from
  # their rims (tests/tools/TestCli.cpp "SurveyTiles").
  tiles="$out/survey-tiles"
  mkdir -p "$tiles"
  gdal_translate -q -of AAIGrid -srcwin 0 0 48 90 "$luxembourg" "$tiles/west.asc"
  gdal_translate -q -of AAIGrid -srcwin 47 0 48 90 "$luxembourg" "$tiles/east.asc"
  punch() {  # file row col...: sets those samples (0-based, after the 6 header lines) to nodata
    local file=$1
    shift
    awk -v cells="$*" 'BEGIN { n = split(cells, a, " "); for (i = 1; i < n; i += 2) hit[a[i] "," a[i + 1]] = 1 }
      /^[a-zA-Z]/ { print; next }
      { row = NR - 7; for (c = 1; c <= NF; ++c) if ((row "," (c - 1)) in hit) $c = -32768; print }' \
      "$file" >"$file.tmp" && mv "$file.tmp" "$file"
  }
  punch "$tiles/west.asc" 40 30 40 31 41 30 41 31
  punch "$tiles/east.asc" 52 15
  rm -f "$tiles"/*.aux.xml
  build survey /usr/share/ferret-vis/data/etopo5.cdf --planet earth --levels 6 \
    --leaf-vertices 17 --inset "$tiles/west.asc" --inset "$tiles/east.asc"
else
  echo "test dataset 'luxembourg' not built: input $luxembourg is missing (set PBDAM_DATA_DIR)"
  [[ "${CI:-}" == "true" ]] && status=1
fi
# The atmosphere's tables of Earth and Mars, computed once into the directory every test's
# PBDAM_CACHE_DIR names (tests/CMakeLists.txt): the commands the tests run then read them instead
# of spending seconds (minutes under the sanitizers) computing them again.
export PBDAM_CACHE_DIR="$out/atmosphere-cache"
mkdir -p "$PBDAM_CACHE_DIR"
for name in mola earth; do
  if [[ -f "$out/$name/manifest.json" ]]; then
    "$pbdam" render "$out/$name" --camera 0,0,1e7 --atmosphere on --width 16 --height 16 --quiet \
      --out "$PBDAM_CACHE_DIR/warm-$name.png"
  fi
done
exit $status

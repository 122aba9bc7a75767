#!/usr/bin/env bash
# Checks, in well under a second, that every external command and file a job runs is present,
# before anything is built: a missing one is named with the Debian package that provides it, so
# a machine set up without it fails at once instead of in a test tens of minutes later.
#   scripts/preflight.sh main    what the main job (scripts/demo.sh) runs: the toolchain, Vulkan
#                                on lavapipe, the built-in default data, ffmpeg
#   scripts/preflight.sh test    all of that, and what the test suite runs: xvfb-run and xauth
#                                (pbdam fly), chromium and node (the browser test), mpirun, clang
#                                and libFuzzer (the fuzzers), curl and GDAL's tools, doxygen (the
#                                API reference), the shared data ($PBDAM_DATA_DIR, default
#                                ../shared/data)
#   scripts/preflight.sh --list MODE   the commands MODE needs, one a line
# Exit status 0 when everything is there, 1 (after naming each missing thing) otherwise. The
# shared data is the exception outside CI: its absence is reported and the tests that read it
# skip, as they say themselves; under CI=true it fails like the rest.
# Uses shell built-ins only, so that it can be run with a PATH that lacks a command on purpose
# (tests/tools/preflight_test.sh does that).
set -uo pipefail
here=${BASH_SOURCE[0]%/*}
[ "$here" != "${BASH_SOURCE[0]}" ] || here=.
root=$(cd "$here/.." && pwd)

# command  package  what needs it
main_commands=(
  "g++ g++ compiling pbdam"
  "cmake cmake configuring the build"
  "ninja ninja-build the build's generator"
  "pkg-config pkg-config finding libraries"
  "ccache ccache compile caching"
  "glslc glslc compiling the shaders"
  "ffmpeg ffmpeg the main job's MP4 (pbdam render --path)"
)
test_commands=(
  "git git the formatting check (git ls-files)"
  "clang-format clang-format the formatting check"
  "clang-tidy clang-tidy scripts/tidy.sh"
  "jq jq scripts/tidy.sh"
  "xvfb-run xvfb pbdam fly's test under an X server without a screen"
  "Xvfb xvfb pbdam fly's test"
  "xauth xauth xvfb-run (xvfb only recommends it)"
  "chromium chromium the browser test"
  "node nodejs the browser test and its driver"
  "mpirun openmpi-bin the distributed-build tests and the README's MPI example"
  "clang++ clang the libFuzzer targets"
  "curl curl the README's serve example"
  "gdal_translate gdal-bin the GeoTIFF tests"
  "gdalinfo gdal-bin the README's examples and the install test"
  "gdalsrsinfo gdal-bin the README's examples"
  "doxygen doxygen the API reference's test (api_reference)"
)
# file  package  what needs it
main_files=(
  "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json mesa-vulkan-drivers Vulkan on lavapipe"
  "/usr/share/ferret-vis/data/etopo5.cdf ferret-datasets the built-in Earth model (ETOPO5)"
  "/usr/share/xplanet/images/earth.jpg xplanet-images the built-in Earth image"
  "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf fonts-dejavu-core pbdam fly's heads-up display"
)
test_files=(
  "/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json vulkan-validationlayers the GPU tests' Khronos validation layer"
  "/usr/share/openuniverse/textures/mars.jpg openuniverse-common the Mars colour map"
  "/usr/lib/llvm-14/lib/clang/*/lib/linux/libclang_rt.fuzzer-x86_64.a libclang-rt-14-dev libFuzzer"
  "$root/tests/browser/node_modules/playwright-core/package.json npm the browser test's driver (scripts/setup_test.sh runs npm ci)"
)

mode=${1:-}
list=0
if [ "$mode" = --list ]; then
  list=1
  mode=${2:-}
fi
case $mode in
  main) commands=("${main_commands[@]}") files=("${main_files[@]}") ;;
  test) commands=("${main_commands[@]}" "${test_commands[@]}")
        files=("${main_files[@]}" "${test_files[@]}") ;;
  *) echo "usage: $0 [--list] main|test" >&2; exit 2 ;;
esac
if [ $list = 1 ]; then
  for entry in "${commands[@]}"; do echo "${entry%% *}"; done
  exit 0
fi

missing=0
for entry in "${commands[@]}"; do
  read -r name package why <<<"$entry"
  if ! command -v "$name" >/dev/null 2>&1; then
    echo "preflight: missing command '$name' (Debian package $package), needed by $why" >&2
    missing=$((missing + 1))
  fi
done
for entry in "${files[@]}"; do
  read -r path package why <<<"$entry"
  # A path with a wildcard (a version in it) is there when anything matches it.
  if ! compgen -G "$path" >/dev/null; then
    echo "preflight: missing file $path (Debian package $package), needed by $why" >&2
    missing=$((missing + 1))
  fi
done
if [ "$mode" = test ]; then
  data=${PBDAM_DATA_DIR:-$root/../shared/data}
  for path in mars/megt90n000cb.img mars/megt90n000cb.lbl mars/megr90n000cb.img \
              geotiff/terra_elev_luxembourg.tif; do
    if [ ! -r "$data/$path" ]; then
      if [ "${CI:-}" = true ]; then
        echo "preflight: missing shared data $data/$path (set PBDAM_DATA_DIR to the folder" \
             "holding shared/data)" >&2
        missing=$((missing + 1))
      else
        echo "preflight: note: $data/$path is missing; the tests that read it will skip" >&2
      fi
    fi
  done
fi
if [ $missing -gt 0 ]; then
  echo "preflight: $missing missing; scripts/setup.sh (main) and scripts/setup_test.sh (test)" \
       "install the packages named" >&2
  exit 1
fi
exit 0

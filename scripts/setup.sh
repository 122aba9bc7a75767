#!/usr/bin/env bash
# Installs the Debian 12 packages that building pbdam and its main job need
# (scripts/packages.txt) when any is missing, then configures and builds the given CMake presets
# (default: release). Compiles go through ccache (its cache in ~/.cache/ccache, kept between
# builds and clones on one machine; CMakeLists.txt sizes it to hold every preset). Idempotent: with every package present it runs no apt command at all.
# Nothing here reaches a registry other than Debian's: the test suite's extras (Chromium, node
# and the npm-installed browser driver) are scripts/setup_test.sh's.
#   scripts/setup.sh [PRESET...]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

scripts/install_packages.sh scripts/packages.txt
# What the build and the main job run is there (each missing one named with its package).
scripts/preflight.sh main

presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(release)
for preset in "${presets[@]}"; do
  # Configured again when the presets changed since, so that their cache variables apply.
  if [ ! -f "build/$preset/build.ninja" ] ||
     [ CMakePresets.json -nt "build/$preset/CMakeCache.txt" ]; then
    cmake --preset "$preset" >/dev/null
  fi
  cmake --build --preset "$preset"
done

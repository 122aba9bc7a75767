#!/usr/bin/env bash
# Installs the Debian 12 packages that building pbdam and its main job need
# (scripts/packages.txt) when any is missing, then configures and builds the given CMake presets
# (default: release). Idempotent: with every package present it runs no apt command at all.
# Nothing here reaches a registry other than Debian's: the test suite's extras (Chromium, node
# and the npm-installed browser driver) are scripts/setup_test.sh's.
#   scripts/setup.sh [PRESET...]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

scripts/install_packages.sh scripts/packages.txt

presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(release)
for preset in "${presets[@]}"; do
  if [ ! -f "build/$preset/build.ninja" ]; then
    cmake --preset "$preset" >/dev/null
  fi
  cmake --build --preset "$preset"
done

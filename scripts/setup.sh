#!/usr/bin/env bash
# Installs the Debian 12 packages pbdam needs (scripts/packages.txt) when any is missing, then
# configures and builds the given CMake presets (default: release). Idempotent: with every
# package present it runs no apt command at all.
#   scripts/setup.sh [PRESET...]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

mapfile -t packages < <(grep -vE '^\s*(#|$)' scripts/packages.txt)
missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)
  [ "$status" = "installed" ] || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  echo "setup: packages installed"
fi

presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(release)
for preset in "${presets[@]}"; do
  if [ ! -f "build/$preset/build.ninja" ]; then
    cmake --preset "$preset" >/dev/null
  fi
  cmake --build --preset "$preset"
done

# The browser test's driver: playwright-core from npm, pinned by tests/browser/package-lock.json
# (node_modules is not committed). Installed when missing or older than the lock file; npm comes
# with NodeSource's nodejs, or from Debian's npm package otherwise.
browser=tests/browser
if [ -f "$browser/package-lock.json" ]; then
  if ! command -v npm >/dev/null 2>&1; then
    echo "setup: installing npm for the browser test"
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends npm >/dev/null
  fi
  if [ ! -f "$browser/node_modules/.package-lock.json" ] ||
     [ "$browser/package-lock.json" -nt "$browser/node_modules/.package-lock.json" ]; then
    echo "setup: npm ci in $browser"
    (cd "$browser" && npm ci --no-audit --no-fund --loglevel=error)
  fi
fi

#!/usr/bin/env bash
# Installs the Debian packages of the given lists (one name a line, # comments) that are not
# installed yet. Idempotent: with every package present it runs no apt command at all.
#   scripts/install_packages.sh LIST...
set -euo pipefail
packages=()
for list in "$@"; do
  mapfile -t -O "${#packages[@]}" packages < <(grep -vE '^\s*(#|$)' "$list")
done
missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)
  [ "$status" = "installed" ] || missing+=("$p")
done
[ ${#missing[@]} -gt 0 ] || exit 0
echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: packages installed"

#!/usr/bin/env bash
# What only the test suite needs beyond scripts/setup.sh: the Debian packages of
# scripts/packages-test.txt (Chromium and node for the browser test) and the browser test's
# driver, playwright-core from npm, pinned by tests/browser/package-lock.json (node_modules is
# not committed). npm comes with NodeSource's nodejs, or from Debian's npm package otherwise.
# Idempotent: npm ci runs only when node_modules is missing or older than the lock file.
#   scripts/setup_test.sh
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"

scripts/install_packages.sh scripts/packages-test.txt
if ! command -v npm >/dev/null 2>&1; then
  echo "setup: installing Debian's npm for the browser test"
  npm_list=$(mktemp)
  echo npm > "$npm_list"
  scripts/install_packages.sh "$npm_list"
  rm -f "$npm_list"
fi

browser=tests/browser
if [ ! -f "$browser/node_modules/.package-lock.json" ] ||
   [ "$browser/package-lock.json" -nt "$browser/node_modules/.package-lock.json" ]; then
  echo "setup: npm ci in $browser"
  (cd "$browser" && npm ci --no-audit --no-fund --loglevel=error)
fi

#!/usr/bin/env bash
# The test command's preflight names a missing command and its package, and fails at once: run
# scripts/preflight.sh with a PATH that holds every command it checks except xauth.
#   preflight_test.sh SOURCE_DIR
set -euo pipefail
src=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir "$tmp/bin"
while read -r name; do
  [ "$name" = xauth ] && continue
  if where=$(command -v "$name"); then ln -s "$where" "$tmp/bin/$name"; fi
done < <("$src/scripts/preflight.sh" --list test)
start=$SECONDS
status=0
PATH="$tmp/bin" /bin/bash "$src/scripts/preflight.sh" test 2>"$tmp/err" || status=$?
cat "$tmp/err"
[ $status -ne 0 ] || { echo "FAIL: the preflight passed without xauth"; exit 1; }
grep -q "missing command 'xauth' (Debian package xauth)" "$tmp/err" ||
  { echo "FAIL: the preflight did not name xauth and its package"; exit 1; }
[ $((SECONDS - start)) -lt 10 ] || { echo "FAIL: the preflight took $((SECONDS - start)) s"; exit 1; }
# With everything on PATH it passes (this machine ran the same preflight before building).
"$src/scripts/preflight.sh" test 2>"$tmp/err" || { cat "$tmp/err"; echo "FAIL: full PATH"; exit 1; }
echo "preflight: fails without xauth, naming it and its package; passes with it"

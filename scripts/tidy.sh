#!/usr/bin/env bash
# Static analysis: clang-tidy with the root .clang-tidy over every translation unit of the
# project in a build's compile_commands.json (formats runtime streaming gpu tools bench tests;
# nothing generated under build/, nothing third-party), one clang-tidy per core. Any finding
# fails (.clang-tidy sets WarningsAsErrors '*'); only the failing files' output is printed.
#   scripts/tidy.sh                      every project translation unit of build/release
#   scripts/tidy.sh BUILD_DIR [REGEX]    another build, or only the files whose path matches
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
build=${1:-build/release}
only=${2:-}
db="$build/compile_commands.json"
if [ ! -f "$db" ]; then
  echo "tidy: $db is missing (configure that preset first: scripts/setup.sh)" >&2
  exit 2
fi
tidy=$(command -v clang-tidy || command -v clang-tidy-14 || true)
if [ -z "$tidy" ]; then
  echo "tidy: clang-tidy not found (scripts/setup.sh installs it)" >&2
  exit 2
fi

# CMake writes one '"file": "/abs/path",' line per compile command; a file built into two
# targets appears twice and is checked once.
mapfile -t files < <(sed -n 's/^ *"file": "\(.*\)",\{0,1\}$/\1/p' "$db" |
  grep -E "^$root/(formats|runtime|streaming|gpu|tools|bench|tests)/" |
  grep -E -e "${only:-.}" | sort -u)
if [ ${#files[@]} -eq 0 ]; then
  echo "tidy: no project translation units in $db${only:+ matching '$only'}" >&2
  exit 2
fi

jobs=$(nproc)
echo "tidy: clang-tidy on ${#files[@]} translation units, $jobs at a time"
start=$SECONDS
# Each file's output is collected and printed in one piece, so parallel runs do not interleave.
status=0
printf '%s\0' "${files[@]}" |
  xargs -0 -n 1 -P "$jobs" sh -c '
    out=$("$0" -p "$1" --quiet "$2" 2>&1) && exit 0
    printf "%s\n" "$out"
    exit 1' "$tidy" "$build" || status=1
echo "tidy: done in $((SECONDS - start)) s"
if [ $status -ne 0 ]; then
  echo "tidy: findings above (fix them, or NOLINT(check) with a reason for a false positive)"
fi
exit $status

#!/usr/bin/env bash
# Static analysis: clang-tidy with the root .clang-tidy over every translation unit of the
# project in a build's compile_commands.json (formats runtime streaming gpu tools bench tests
# examples, and the unity batches CMake writes under build/ for the command line, each of which
# includes its sources; nothing else generated, nothing third-party), one clang-tidy per core.
# Any finding fails (.clang-tidy sets WarningsAsErrors '*'); only the failing files' output is
# printed.
# A batch is checked once for all its sources: the heavy headers they share (CLI11,
# nlohmann-json) are analysed once instead of six times.
#   scripts/tidy.sh                      every project translation unit of build/release
#   scripts/tidy.sh BUILD_DIR [REGEX]    another build, or only the units whose path (or, for a
#                                        batch, one of whose sources' paths) matches
# A clean result is cached per translation unit in $PBDAM_TIDY_CACHE (default
# ~/.cache/pbdam/tidy), keyed by what clang-tidy's verdict depends on: the translation unit as
# clang preprocesses it with its compile command, comments kept (so NOLINT counts), every
# header it includes expanded in place (so a header's change re-checks every file including
# it), the compile command itself, .clang-tidy and clang-tidy's version (the checkout's path is
# masked, so clones elsewhere on the machine share the cache). A unit whose key was
# checked clean before is not checked again; findings are never cached. PBDAM_TIDY_CACHE=off
# checks every unit.
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
# targets appears twice and is checked once. A unity batch is selected by its sources' paths.
unity="$root/build/[^/]+/(tools|tests/[a-z]+)/CMakeFiles/[a-z_]+\.dir/Unity/unity_[0-9]+_cxx\.cxx"
mapfile -t files < <(sed -n 's/^ *"file": "\(.*\)",\{0,1\}$/\1/p' "$db" |
  grep -E "^($root/(formats|runtime|streaming|gpu|tools|bench|tests|examples)/|$unity\$)" | sort -u |
  while read -r file; do
    if [[ $file =~ ^$unity$ ]]; then
      sed -n 's/^#include "\(.*\)"$/\1/p' "$file" | grep -q -E -e "${only:-.}" && echo "$file"
    else
      grep -q -E -e "${only:-.}" <<< "$file" && echo "$file"
    fi
  done)
if [ ${#files[@]} -eq 0 ]; then
  echo "tidy: no project translation units in $db${only:+ matching '$only'}" >&2
  exit 2
fi

jobs=$(nproc)
cache=${PBDAM_TIDY_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/pbdam/tidy}
clangxx=$(command -v clang++ || command -v clang++-14 || true)
if [ "$cache" != off ] && [ -z "$clangxx" ]; then
  echo "tidy: clang++ not found, so no cache (scripts/setup.sh installs clang)" >&2
  cache=off
fi
# What every key shares: the checker and its configuration.
salt=$({ "$tidy" --version; cat .clang-tidy; } | sha256sum | cut -c1-64)
echo "tidy: clang-tidy on ${#files[@]} translation units, $jobs at a time" \
  "(cache: ${cache})"
start=$SECONDS
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# One compile command per file (the first, for a file built into two targets), as a shell
# command line that preprocesses it with clang++ to stdout.
if [ "$cache" != off ]; then
  mkdir -p "$cache"
  jq -r --arg cxx "$clangxx" '
    group_by(.file)[] | .[0] |
    [.file, "cd \(.directory | @sh) && \(.command | sub("^[^ ]+ "; "\($cxx) ")
       | sub(" -o [^ ]+ "; " ") | sub(" -c "; " ")) -E -C"] | @tsv' "$db" > "$work/commands"
fi
# Each file's output is collected and printed in one piece, so parallel runs do not interleave.
status=0
printf '%s\0' "${files[@]}" |
  xargs -0 -n 1 -P "$jobs" sh -c '
    tidy=$0 build=$1 cache=$2 salt=$3 commands=$4 root=$5 file=$6
    key=""
    if [ "$cache" != off ]; then
      pre=$(awk -F "\t" -v f="$file" "\$1 == f { print \$2; exit }" "$commands")
      if [ -n "$pre" ]; then
        key=$({ echo "$salt"; echo "$pre"; sh -c "$pre" 2>&1; } |
          sed "s|$root|<root>|g" | sha256sum | cut -c1-64)
        [ -f "$cache/$key" ] && exit 0
      fi
    fi
    if out=$("$tidy" -p "$build" --quiet "$file" 2>&1); then
      [ -z "$key" ] || : > "$cache/$key"
      exit 0
    fi
    printf "%s\n" "$out"
    exit 1' "$tidy" "$build" "$cache" "$salt" "$work/commands" "$root" ||
  status=1
echo "tidy: done in $((SECONDS - start)) s"
if [ $status -ne 0 ]; then
  echo "tidy: findings above (fix them, or NOLINT(check) with a reason for a false positive)"
fi
exit $status

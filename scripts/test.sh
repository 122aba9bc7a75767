#!/usr/bin/env bash
# The whole test suite (README command 2; .ci/run calls exactly this): set up, build and test the
# release preset, then the ASan+UBSan and TSan presets, then clang-tidy (scripts/tidy.sh) and the
# formatting check. GPU tests run on lavapipe with the Khronos validation layer on; any
# validation message fails them. Compiles go through ccache and clang-tidy keeps a per-unit
# cache (both in ~/.cache), so a second run on one machine rebuilds and re-checks only what
# changed. Each phase's wall time is printed at the end.
#   scripts/test.sh            everything but tests labelled "long"
#   PBDAM_TEST_PRESETS="release" scripts/test.sh   only some presets
#   PBDAM_SKIP_TIDY=1 scripts/test.sh              no clang-tidy (local use; ignored when CI=true)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
presets=${PBDAM_TEST_PRESETS:-"release asan tsan"}
jobs=$(nproc)

phases=()
# phase NAME COMMAND...: runs the command, records its wall time; returns its status.
phase() {
  local name=$1 start=$SECONDS rc=0
  shift
  "$@" || rc=$?
  phases+=("$(printf '%-22s %5d s%s' "$name" $((SECONDS - start)) "$([ $rc -eq 0 ] || echo '  FAILED')")")
  return $rc
}
summary() {
  echo "== wall time per phase"
  printf '%s\n' "${phases[@]}"
  printf '%-22s %5d s\n' "total" "$SECONDS"
}
trap summary EXIT

# The test-only extras first, so that configuring sees them.
phase "setup" sh -c 'scripts/setup_test.sh && scripts/install_packages.sh scripts/packages.txt'
# Every command and file the suite runs is there before anything is built (the missing ones are
# named with their packages), so a machine without one fails now rather than in a test later.
phase "preflight" scripts/preflight.sh test
for preset in $presets; do
  phase "build $preset" scripts/setup.sh "$preset"
done

status=0
for preset in $presets; do
  echo "== ctest --preset $preset"
  phase "test $preset" ctest --preset "$preset" -j "$jobs" --timeout 600 || status=1
done

# clang-tidy reads the compile commands of the release build (or of the first preset run).
echo "== clang-tidy"
tidy_preset=release
case " $presets " in *" release "*) ;; *) tidy_preset=${presets%% *} ;; esac
if [ "${PBDAM_SKIP_TIDY:-}" = 1 ] && [ "${CI:-}" != true ]; then
  echo "clang-tidy skipped (PBDAM_SKIP_TIDY=1)"
else
  phase "clang-tidy" scripts/tidy.sh "build/$tidy_preset" || status=1
fi

echo "== clang-format check"
format_check() {
  if ! git ls-files '*.h' '*.cpp' | xargs clang-format --dry-run -Werror; then
    echo "clang-format: files above differ from .clang-format (run scripts/format.sh)"
    return 1
  fi
}
phase "clang-format" format_check || status=1
exit $status

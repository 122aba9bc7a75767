#!/usr/bin/env bash
# The whole test suite (README command 2; .ci/run calls exactly this): set up, build and test the
# release preset, then the ASan+UBSan and TSan presets, then clang-tidy (scripts/tidy.sh) and the
# formatting check. GPU tests run on lavapipe with the Khronos validation layer on; any
# validation message fails them.
#   scripts/test.sh            everything but tests labelled "long"
#   PBDAM_TEST_PRESETS="release" scripts/test.sh   only some presets
#   PBDAM_SKIP_TIDY=1 scripts/test.sh              no clang-tidy (local use; ignored when CI=true)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
presets=${PBDAM_TEST_PRESETS:-"release asan tsan"}
jobs=$(nproc)

# The test-only extras first, so that configuring sees them.
scripts/setup_test.sh
# shellcheck disable=SC2086
scripts/setup.sh $presets

status=0
for preset in $presets; do
  echo "== ctest --preset $preset"
  if ! ctest --preset "$preset" -j "$jobs" --timeout 600; then status=1; fi
done

# clang-tidy reads the compile commands of the release build (or of the first preset run).
echo "== clang-tidy"
tidy_preset=release
case " $presets " in *" release "*) ;; *) tidy_preset=${presets%% *} ;; esac
if [ "${PBDAM_SKIP_TIDY:-}" = 1 ] && [ "${CI:-}" != true ]; then
  echo "clang-tidy skipped (PBDAM_SKIP_TIDY=1)"
elif ! scripts/tidy.sh "build/$tidy_preset"; then
  status=1
fi

echo "== clang-format check"
if ! git ls-files '*.h' '*.cpp' | xargs clang-format --dry-run -Werror; then
  echo "clang-format: files above differ from .clang-format (run scripts/format.sh)"
  status=1
fi
exit $status

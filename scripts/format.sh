#!/usr/bin/env bash
# Formats every tracked C++ file with the project's .clang-format.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
git ls-files '*.h' '*.cpp' | xargs clang-format -i

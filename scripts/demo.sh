#!/usr/bin/env bash
# The main job on the built-in default data (README command 1): set up, build, and run the
# furthest real step that exists today — inspecting the Debian-packaged ETOPO5 Earth model and
# sampling it at Mount Everest and in the Mariana Trench.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/setup.sh" release >/dev/null
pbdam="$root/build/release/tools/pbdam"
etopo5=/usr/share/ferret-vis/data/etopo5.cdf
"$pbdam" dem info "$etopo5" --at 27.988,86.925
"$pbdam" dem info "$etopo5" --at 11.35,142.2 --json

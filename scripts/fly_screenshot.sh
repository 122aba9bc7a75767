#!/usr/bin/env bash
# Regenerates docs/images/fly.png: `pbdam fly` over the MOLA test dataset in a window on a
# private X server (Xvfb), its heads-up display and help on, captured from the screen with
# ffmpeg's x11grab after the flight has settled.
#   scripts/fly_screenshot.sh [PBDAM] [DATASET]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
pbdam=${1:-$root/build/release/tools/pbdam}
dataset=${2:-$root/build/testdata/mola}
display=:$((90 + RANDOM % 9))
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$work"' EXIT
Xvfb "$display" -screen 0 1280x720x24 -nolisten tcp >/dev/null 2>&1 &
sleep 1
printf '0.2 key f1\n' > "$work/script.txt"
DISPLAY=$display PBDAM_DEVICE=lavapipe "$pbdam" fly "$dataset" --width 1280 --height 720 \
  --camera=15.2,-133.9,90e3,0,-22,0 --script "$work/script.txt" --exit-after-s 9 >/dev/null &
sleep 7
ffmpeg -loglevel error -y -f x11grab -draw_mouse 0 -video_size 1280x720 -i "$display" -frames:v 1 \
  "$root/docs/images/fly.png"
wait %2
echo "wrote docs/images/fly.png"

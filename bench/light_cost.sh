#!/usr/bin/env bash
# The frame cost of light and air: the Mars flight (bench/paths/mars_flight.csv, its first FRAMES
# poses) replayed by `pbdam bench` at 1280 × 720, 3 px, prefetch off, morph on, four ways side by
# side, interleaved ROUNDS times: the camera light with the atmosphere off (the frames of before),
# the sun of an instant with the atmosphere off (lit), the sun with the atmosphere (lit + air), and
# that without the normal maps (--normal-maps off: what they cost). Prints the median frame time
# of each and the ratios to the first; the issue's bound is lit + air ≤ 1.3× both off.
#   bench/light_cost.sh [DATASET] [FRAMES] [ROUNDS]
# Defaults: build/testdata/mola, 300, 2. PBDAM: the binary (default build/release/tools/pbdam).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dataset=${1:-$root/build/testdata/mola}
frames=${2:-300}
rounds=${3:-2}
pbdam=${PBDAM:-$root/build/release/tools/pbdam}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
head -n "$((frames + 1))" "$root/bench/paths/mars_flight.csv" >"$out/path.csv"
time="2004-01-03T16:00:00Z"  # morning over the flight's start (Mars24's example B, 2 h 13 min on)
declare -A light=([off]="--atmosphere off" [lit]="--time $time --atmosphere off"
                  [air]="--time $time --atmosphere on"
                  [flat]="--time $time --atmosphere on --normal-maps off")
for round in $(seq "$rounds"); do
  for name in off lit air flat; do
    # shellcheck disable=SC2086
    "$pbdam" bench "$dataset" --path "$out/path.csv" --out "$out/$name-$round" --width 1280 \
      --height 720 --tolerance-px 3 --prefetch off --morph on --quiet ${light[$name]} \
      >"$out/$name-$round.log" 2>&1 || { cat "$out/$name-$round.log" >&2; exit 1; }
    jq -r '.runs[0].frame_ms_p50' "$out/$name-$round/summary.json" >>"$out/$name.p50"
  done
done
median() { sort -g "$1" | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
off=$(median "$out/off.p50")
lit=$(median "$out/lit.p50")
air=$(median "$out/air.p50")
flat=$(median "$out/flat.p50")
echo "| light | frame p50 ms | × camera light, no air |"
echo "|---|---|---|"
awk -v off="$off" -v lit="$lit" -v air="$air" -v flat="$flat" 'BEGIN {
  printf "| camera light, atmosphere off | %.1f | 1.00 |\n", off
  printf "| sun (--time), atmosphere off | %.1f | %.2f |\n", lit, lit / off
  printf "| sun (--time), atmosphere on | %.1f | %.2f |\n", air, air / off
  printf "| the same, --normal-maps off | %.1f | %.2f |\n", flat, flat / off }'
echo "($frames poses of bench/paths/mars_flight.csv, $rounds interleaved rounds, medians of the runs' p50)"

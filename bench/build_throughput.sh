#!/usr/bin/env bash
# Build throughput on ETOPO5 (issue: >= 1 M input samples/s per thread): builds the same dataset
# with 1 and 2 threads, side by side in one run, and prints input samples/s and the speed-up.
#   bench/build_throughput.sh [LEVELS]     (default 8: a 512-cell lattice; 'auto' = full density)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
pbdam="$root/build/release/tools/pbdam"
dem=/usr/share/ferret-vis/data/etopo5.cdf
levels=${1:-8}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
samples=$(( 4320 * 2161 ))
declare -A seconds
for threads in 1 2; do
  start=$(date +%s.%N)
  "$pbdam" build --dem "$dem" --planet earth --levels "$levels" --threads "$threads" \
    --out "$out/t$threads" --quiet >/dev/null
  end=$(date +%s.%N)
  seconds[$threads]=$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')
  awk -v t="$threads" -v s="${seconds[$threads]}" -v n="$samples" 'BEGIN {
    printf "threads=%d  %.1f s  %.3f M input samples/s  (%.3f M/s per thread)\n", t, s, n / s / 1e6,
           n / s / 1e6 / t }'
done
cmp -s "$out/t1/face0.pbdam" "$out/t2/face0.pbdam" && echo "1- and 2-thread outputs are byte-identical"
awk -v a="${seconds[1]}" -v b="${seconds[2]}" 'BEGIN { printf "speed-up 2 threads vs 1: %.2fx\n", a / b }'

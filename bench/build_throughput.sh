#!/usr/bin/env bash
# Build throughput on ETOPO5 (issue: >= 1 M input samples/s per thread): builds the same dataset
# with 1 and 2 threads, side by side in one run, and prints wall and CPU seconds, input samples/s
# (per thread and per CPU-second), peak RSS and the speed-up, and compares every face file and
# the manifest of the two.
#   bench/build_throughput.sh [LEVELS] [PBDAM]
#     LEVELS  bintree depth (even) or 'auto' (default: the input's full density, a 2048-cell
#             lattice for ETOPO5; 8 gives a quick 512-cell run)
#     PBDAM   the pbdam binary (default: build/release/tools/pbdam)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
levels=${1:-auto}
pbdam=${2:-"$root/build/release/tools/pbdam"}
dem=/usr/share/ferret-vis/data/etopo5.cdf
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
samples=$(( 4320 * 2161 ))
declare -A seconds
for threads in 1 2; do
  /usr/bin/time -f "%e %U %S %M" -o "$out/time$threads" \
    "$pbdam" build --dem "$dem" --planet earth --levels "$levels" --threads "$threads" \
    --out "$out/t$threads" --quiet >/dev/null
  read -r wall user sys rss <"$out/time$threads"
  seconds[$threads]=$wall
  awk -v t="$threads" -v s="$wall" -v u="$user" -v y="$sys" -v r="$rss" -v n="$samples" 'BEGIN {
    printf "threads=%d  wall %.1f s  cpu %.1f s  %.3f M input samples/s  (%.3f M/s per thread, %.3f M per cpu-s)  peak RSS %.0f MiB\n",
           t, s, u + y, n / s / 1e6, n / s / 1e6 / t, n / (u + y) / 1e6, r / 1024 }'
done
same=yes
for f in "$out"/t1/face*.pbdam "$out"/t1/manifest.json; do
  cmp -s "$f" "$out/t2/$(basename "$f")" || { same=no; echo "differs: $(basename "$f")"; }
done
[ "$same" = yes ] && echo "1- and 2-thread outputs are byte-identical (every face file and the manifest)"
awk -v a="${seconds[1]}" -v b="${seconds[2]}" 'BEGIN { printf "speed-up 2 threads vs 1: %.2fx\n", a / b }'

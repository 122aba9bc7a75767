#!/usr/bin/env bash
# Build throughput on ETOPO5 (issue: >= 1 M input samples/s per thread): builds the same dataset
# with 1 and 2 threads, side by side in one run, and prints wall and CPU seconds, input samples/s
# (per thread and per CPU-second), peak RSS and the speed-up, and compares every face file and
# the manifest of the two.
# With a second binary BEFORE, it first builds the same dataset with it on 1 thread and prints
# its figures and per-stage CPU seconds beside the current binary's, and compares their outputs.
#   bench/build_throughput.sh [LEVELS] [PBDAM] [BEFORE]
#     LEVELS  bintree depth (even) or 'auto' (default: the input's full density, a 2048-cell
#             lattice for ETOPO5; 8 gives a quick 512-cell run)
#     PBDAM   the pbdam binary (default: build/release/tools/pbdam)
#     BEFORE  an earlier pbdam binary to compare with (optional)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
levels=${1:-auto}
pbdam=${2:-"$root/build/release/tools/pbdam"}
before=${3:-}
dem=/usr/share/ferret-vis/data/etopo5.cdf
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
samples=$(( 4320 * 2161 ))
declare -A seconds
# run LABEL BINARY THREADS: one build, its figures and its CPU seconds per stage (--stats).
run() {
  local label=$1 binary=$2 threads=$3
  /usr/bin/time -f "%e %U %S %M" -o "$out/time$label" \
    "$binary" build --dem "$dem" --planet earth --levels "$levels" --threads "$threads" \
    --out "$out/$label" --stats "$out/$label.json" --quiet >/dev/null
  read -r wall user sys rss <"$out/time$label"
  seconds[$label]=$wall
  awk -v t="$label" -v s="$wall" -v u="$user" -v y="$sys" -v r="$rss" -v n="$samples" -v k="$threads" 'BEGIN {
    printf "%-7s wall %.1f s  cpu %.1f s  %.3f M input samples/s  (%.3f M/s per thread, %.3f M per cpu-s)  peak RSS %.0f MiB\n",
           t, s, u + y, n / s / 1e6, n / s / 1e6 / k, n / (u + y) / 1e6, r / 1024 }'
  python3 - "$out/$label.json" <<'PY'
import json, sys
cpu = json.load(open(sys.argv[1]))["cpu_seconds"]
levels = [k for k in cpu if k.startswith("level ")]
parts = [f"{k} {cpu[k]:.1f}" for k in cpu if not k.startswith("level ") and k != "total"]
print("        cpu-s per stage: " + ", ".join(parts) + f" (levels {sum(cpu[k] for k in levels):.1f})")
print("        cpu-s per level: " + ", ".join(f"{k[6:]}: {cpu[k]:.1f}" for k in levels))
PY
}
if [ -n "$before" ]; then
  run before "$before" 1
fi
run t1 "$pbdam" 1
run t2 "$pbdam" 2
same=yes
for f in "$out"/t1/face*.pbdam "$out"/t1/manifest.json; do
  cmp -s "$f" "$out/t2/$(basename "$f")" || { same=no; echo "differs: $(basename "$f")"; }
done
[ "$same" = yes ] && echo "1- and 2-thread outputs are byte-identical (every face file and the manifest)"
awk -v a="${seconds[t1]}" -v b="${seconds[t2]}" 'BEGIN { printf "speed-up 2 threads vs 1: %.2fx\n", a / b }'
if [ -n "$before" ]; then
  same=yes
  for f in "$out"/before/face*.pbdam "$out"/before/manifest.json; do
    cmp -s "$f" "$out/t1/$(basename "$f")" || { same=no; echo "differs from before: $(basename "$f")"; }
  done
  [ "$same" = yes ] && echo "outputs are byte-identical to those of $before"
  awk -v a="$(awk '{print $2 + $3}' "$out/timebefore")" -v b="$(awk '{print $2 + $3}' "$out/timet1")" \
    'BEGIN { printf "cpu before / after (1 thread): %.2fx\n", a / b }'
fi

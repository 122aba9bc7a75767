#!/usr/bin/env bash
# `pbdam fly` measured against `pbdam bench`: the scripted flight of tests/tools/fly_flight.txt
# (without its resize, so every frame is WIDTHxHEIGHT) flown in a window on a private X server
# (Xvfb) over DATASET, no-stall mode with prefetch (fly's defaults), its path recorded; then the
# recorded path replayed by `pbdam bench --mode no-stall --prefetch on` at the same size and
# tolerance. Prints the window's frame p99 and its longest frame after the first second, bench's
# frame p99, and their ratio (docs/performance.md "pbdam fly").
#   bench/fly_flight.sh [DATASET] [WIDTH HEIGHT TOLERANCE_PX]
# Defaults: build/testdata/mola, 1280 720 3. PBDAM: the binary (default build/release/tools/pbdam).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dataset=${1:-$root/build/testdata/mola}
width=${2:-1280}
height=${3:-720}
tolerance=${4:-3}
pbdam=${PBDAM:-$root/build/release/tools/pbdam}
command -v xvfb-run >/dev/null || { echo "fly_flight: xvfb-run is missing (apt-get install xvfb)" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
grep -v ' resize ' "$root/tests/tools/fly_flight.txt" > "$out/script.txt"
xvfb-run -a -s "-screen 0 $((width + 64))x$((height + 64))x24" \
  "$pbdam" fly "$dataset" --width "$width" --height "$height" --tolerance-px "$tolerance" \
  --camera=-8,-75,300000,90,-35,0 --script "$out/script.txt" --record "$out/flight.csv" \
  --screenshots "$out/shot" --stats "$out/fly.json" >/dev/null
"$pbdam" bench "$dataset" --path "$out/flight.csv" --out "$out/bench" --width "$width" \
  --height "$height" --tolerance-px "$tolerance" --mode no-stall --prefetch on --quiet >/dev/null
python3 - "$out/fly.json" "$out/bench/summary.json" <<'PY'
import json, sys
fly = json.load(open(sys.argv[1]))
bench = json.load(open(sys.argv[2]))["runs"][0]
print(f"fly:   {fly['frames']} frames at {fly['width']}x{fly['height']}, {fly['fps_mean']:.1f} fps, "
      f"frame p50 {fly['frame_ms_p50']:.1f} ms, p99 {fly['frame_ms_p99']:.1f} ms, "
      f"max after the first second {fly['frame_ms_max_after_1s']:.1f} ms, "
      f"render-thread faults {fly['render_thread_major_faults']}, data stalls {fly['data_stalls']}")
print(f"bench: {bench['frames']} frames, {bench['fps_mean']:.1f} fps, frame p50 "
      f"{bench['frame_ms_p50']:.1f} ms, p99 {bench['frame_ms_p99']:.1f} ms")
print(f"fly p99 / bench p99: {fly['frame_ms_p99'] / bench['frame_ms_p99']:.2f}")
PY

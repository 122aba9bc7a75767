#!/usr/bin/env bash
# What an inset costs (hybrid datasets): MOLA alone, then MOLA with a synthetic inset of
# 8192 × 8192 samples at 256 px/deg (32° × 32° under the Mars flight's last leg, fractal detail
# from pbdam_fractal_dem), built one after the other with the same threads. Prints the extra
# build CPU-seconds and extra dataset bytes over the base-only build, each as a multiple of
# (inset samples × the base build's CPU-seconds or bytes per source sample): the target is 2 at
# most. Then replays the Mars flight cold through both datasets (pbdam bench: paging mode with
# prefetch on and off, and no-stall mode) and prints the render-thread major faults and data
# stalls of each, their ratio, and how many no-stall frames were drawn under a level cap.
#   bench/inset_cost.sh [OUTDIR] [PBDAM]
#     OUTDIR  where the inset, datasets and reports go (default build/inset; kept)
#     PBDAM   the pbdam binary (default build/release/tools/pbdam)
# Environment: PBDAM_DATA_DIR (default ../shared/data), INSET_THREADS (default 2),
# INSET_GPU_CACHE_MIB (the flights' GPU cache budget, default 256: the inset's last leg draws
# twice the base's triangles, which a 64 MiB cache keeps re-decoding), INSET_REUSE=1 (replay the
# flights over the datasets of an earlier run instead of building them again), INSET_BASE_RUNS
# (the base build is repeated and its median CPU time used, default 5), INSET_VERIFY=1
# to verify the inset dataset against MOLA and the inset too (slow).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-"$root/build/inset"}
pbdam=${2:-"$root/build/release/tools/pbdam"}
fractal="$(dirname "$pbdam")/../bench/pbdam_fractal_dem"
data=${PBDAM_DATA_DIR:-"$root/../shared/data"}
mola="$data/mars/megt90n000cb.lbl"
threads=${INSET_THREADS:-2}
gpu_cache=${INSET_GPU_CACHE_MIB:-256}
flight="$root/bench/paths/mars_flight.csv"
mkdir -p "$out"
inset="$out/olympus_256.tif"
if [ ! -f "$inset" ]; then
  "$fractal" --dem "$mola" --out "$inset" --width 8192 --bounds 2,210,34,242 --seed 7
fi

build() {  # NAME RUNS [ARGS...]: RUNS builds, the one of median CPU-seconds kept in NAME.time
  local name=$1 runs=$2
  shift 2
  if [ "${INSET_REUSE:-0}" = 1 ] && [ -f "$out/$name/manifest.json" ] && [ -f "$out/$name.time" ]; then
    echo "$name: reusing $out/$name"
    return
  fi
  for ((k = 1; k <= runs; ++k)); do
    rm -rf "${out:?}/$name"
    /usr/bin/time -f "%e %U %S %M" -o "$out/$name.time.$k" \
      "$pbdam" build --dem "$mola" --planet mars --threads "$threads" --out "$out/$name" "$@" \
      >"$out/$name.log" 2>&1
  done
  for ((k = 1; k <= runs; ++k)); do
    awk '{print $2 + $3, FILENAME}' "$out/$name.time.$k"
  done | sort -n | awk -v m=$(((runs + 1) / 2)) 'NR == m {print $2}' | xargs -I{} cp {} "$out/$name.time"
  rm -f "$out/$name".time.*
  read -r wall user sys rss <"$out/$name.time"
  bytes=$(du -sb --exclude=.build-checkpoint "$out/$name" | cut -f1)
  echo "$name: wall $wall s, cpu $(awk -v u="$user" -v s="$sys" 'BEGIN{print u+s}') s, peak RSS $((rss / 1024)) MiB, $bytes bytes"
}
# The base build takes seconds and its CPU time varies by a quarter from run to run: the budget
# below divides by it, so it is the median of INSET_BASE_RUNS builds (default 5).
build base "${INSET_BASE_RUNS:-5}"
build inset 1 --inset "$inset"
# verify checks every inset sample at each of its 20 levels: over 20 minutes here.
if [ "${INSET_VERIFY:-0}" = 1 ]; then
  "$pbdam" verify "$out/inset" --dem "$mola" --inset "$inset" --quiet
fi

base_samples=$(( 1440 * 720 ))
inset_samples=$(( 8192 * 8192 ))
read -r _ bu bs _ <"$out/base.time"
read -r _ iu is _ <"$out/inset.time"
bb=$(du -sb --exclude=.build-checkpoint "$out/base" | cut -f1)
ib=$(du -sb --exclude=.build-checkpoint "$out/inset" | cut -f1)
awk -v bu="$bu" -v bs="$bs" -v iu="$iu" -v is="$is" -v bb="$bb" -v ib="$ib" \
    -v n="$base_samples" -v m="$inset_samples" 'BEGIN {
  base = bu + bs; with = iu + is
  printf "extra CPU   %.1f s = %.2f x (inset samples x base CPU-s per sample = %.1f s); target <= 2\n",
         with - base, (with - base) / (m * base / n), m * base / n
  printf "extra bytes %.1f MB = %.2f x (inset samples x base bytes per sample = %.1f MB); target <= 2\n",
         (ib - bb) / 1e6, (ib - bb) / (m * bb / n), m * bb / n / 1e6
}'

for name in base inset; do
  rm -rf "${out:?}/$name-flight" "${out:?}/$name-nostall"
  "$pbdam" bench "$out/$name" --path "$flight" --out "$out/$name-flight" --cold --quiet \
    --gpu-cache-mib "$gpu_cache" \
    >"$out/$name-flight.log" 2>&1
  # No-stall mode: the render thread never waits on disk; it draws the finest conforming cut
  # whose data is resident (a global level cap) while the prefetcher loads the rest.
  "$pbdam" bench "$out/$name" --path "$flight" --out "$out/$name-nostall" --cold --quiet \
    --gpu-cache-mib "$gpu_cache" \
    --mode no-stall --prefetch on >"$out/$name-nostall.log" 2>&1
done
python3 - "$out" <<'EOF'
import csv, json, sys
out = sys.argv[1]
runs = {}
for name in ("base", "inset"):
    for kind in ("flight", "nostall"):
        with open(f"{out}/{name}-{kind}/summary.json") as f:
            for run in json.load(f)["runs"]:
                runs[(name, run["mode"], run["prefetch"])] = run
for mode, prefetch in (("paging", "off"), ("paging", "on"), ("no-stall", "on")):
    b, i = runs[("base", mode, prefetch)], runs[("inset", mode, prefetch)]
    for key in ("render_thread_major_faults", "render_thread_major_faults_after_first_frame",
                "data_stalls"):
        ratio = i[key] / b[key] if b[key] else float("nan")
        print(f"flight {mode} prefetch {prefetch}: {key} base {b[key]}, inset {i[key]}, "
              f"ratio {ratio:.2f} (target <= 1.2)")
    print(f"flight {mode} prefetch {prefetch}: triangles per frame base "
          f"{b['triangles_per_frame_mean']:.0f}, inset {i['triangles_per_frame_mean']:.0f}")
# What no-stall mode gives up for it: frames drawn under a level cap below the dataset's depth.
for name in ("base", "inset"):
    with open(f"{out}/{name}/manifest.json") as f:
        depth = json.load(f)["depth"]
    with open(f"{out}/{name}-nostall/frames.csv") as f:
        caps = [int(r["level_cap"]) for r in csv.DictReader(f)]
    capped = sum(1 for c in caps if c < depth)
    print(f"no-stall {name}: {capped} of {len(caps)} frames capped below depth {depth}, "
          f"lowest cap {min(caps)}")
EOF

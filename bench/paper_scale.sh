#!/usr/bin/env bash
# The paper-scale distributed build ([P-BDAM 2003] §5-6: Mars, 6 faces of ~13,313² samples
# built on five PCs in 6 h 10 min): MOLA 4 px/deg upsampled with deterministic fractal detail
# (bench/fractal_dem.cpp) and built into a 16384-cell lattice per face side — 6 × 16385² =
# 1.61 G lattice samples — once per RANKSxTHREADS configuration through mpirun. Per
# configuration it records wall time, CPU seconds and peak RSS of every rank (/usr/bin/time),
# samples/s, parallel efficiency against the first configuration's CPU seconds, the dataset size
# with and without patch compression, and the SHA-256 of every output file; outputs are compared
# by checksum (two 25+ GB datasets do not fit on the disk side by side), then all but the last
# are deleted, and the last is checked with `pbdam verify --dem`. A script, not a test: it takes
# hours.
#
# Interrupted (a killed job, a machine that went away)? Run it again: a configuration whose
# output is complete is not rebuilt, and one with a checkpoint resumes from its last completed
# level (`pbdam build --resume`); the time of every completed segment is logged and summed (a
# segment that was killed leaves only its start line in OUTDIR/paper_scale.log).
#
#   bench/paper_scale.sh [OUTDIR]                  (default build/paper)
# Environment: PBDAM_DATA_DIR (default ../shared/data), PAPER_WIDTH (fractal DEM columns,
# default 32768: 537 M source samples), PAPER_LEVELS (default 18: 16384 cells with 33-vertex
# leaves), PAPER_CONFIGS (default "1x2 2x1"), PAPER_VERIFY (default 1), PAPER_MIN_FREE_GB
# (default 48: the free disk a configuration needs — node parts ~32 GB, heights and samples
# ~8 GB until the assembly, then one face file at a time beside the parts, whose pages the
# assembly frees as it goes when the disk is short (`pbdam build --free-checkpoint auto`,
# docs/builder.md "Disk at assembly"); the script refuses to start a build with less, and deletes
# a failed build's files when it left the disk nearly full), PAPER_PBDAM (the pbdam binary to run,
# default the release build's: a copy keeps a long run independent of rebuilds meanwhile).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$root/scripts/setup.sh" release >/dev/null
bin="$root/build/release"
pbdam=${PAPER_PBDAM:-"$bin/tools/pbdam"}
data=${PBDAM_DATA_DIR:-"$root/../shared/data"}
mola="$data/mars/megt90n000cb.lbl"
[ -f "$mola" ] || { echo "paper_scale.sh: $mola not found (set PBDAM_DATA_DIR)" >&2; exit 2; }
command -v mpirun >/dev/null || { echo "paper_scale.sh: mpirun not found (openmpi-bin)" >&2; exit 2; }
out=${1:-"$root/build/paper"}
width=${PAPER_WIDTH:-32768}
levels=${PAPER_LEVELS:-18}
configs=${PAPER_CONFIGS:-"1x2 2x1"}
verify=${PAPER_VERIFY:-1}
minFreeGb=${PAPER_MIN_FREE_GB:-48}
asroot=()
[ "$(id -u)" -eq 0 ] && asroot=(--allow-run-as-root)
mkdir -p "$out"
log="$out/paper_scale.log"
say() { echo "$*" | tee -a "$log"; }

freeGb() { df -P -B1G "$out" | awk 'NR == 2 { print $4 }'; }
dem="$out/mola_fractal_${width}.tif"
# bench/large_data.sh makes the same DEM (same arguments, same bytes): reuse it.
if [ ! -f "$dem" ] && [ -f "$root/build/large/mola_fractal_${width}.tif" ]; then
  ln -s "$root/build/large/mola_fractal_${width}.tif" "$dem"
fi
if [ ! -f "$dem" ]; then
  say "fractal DEM: $dem ($(date -u +%FT%TZ))"
  "$bin/bench/pbdam_fractal_dem" --dem "$mola" --out "$dem.tmp.tif" --width "$width" --seed 1
  mv "$dem.tmp.tif" "$dem"
fi
say "paper scale: $dem, --levels $levels, configurations $configs; $(nproc) cores; $(date -u +%FT%TZ)"

last=""
for config in $configs; do last=$config; done
for config in $configs; do
  ranks=${config%x*}
  threads=${config#*x}
  dir="$out/out-$config"
  times="$out/times-$config.txt"  # one line per segment: wall_s, then "rss_kb user_s sys_s" per rank
  if [ -f "$out/sha-$config.txt" ]; then
    say "$config: already built (checksums in $out/sha-$config.txt)"
    continue
  fi
  resume=()
  if [ -d "$dir/.build-checkpoint" ]; then
    resume=(--resume)
    say "$config: resuming from $dir/.build-checkpoint"
  else
    rm -rf "$dir"
    : >"$times"
  fi
  if [ ${#resume[@]} -eq 0 ] && [ "$(freeGb)" -lt "$minFreeGb" ]; then
    say "$config: only $(freeGb) GB free on $out, the build needs about $minFreeGb GB (PAPER_MIN_FREE_GB); not started"
    exit 1
  fi
  say "$config: $ranks rank(s) x $threads thread(s), started $(date -u +%FT%TZ), load $(cut -d' ' -f1-3 /proc/loadavg)"
  start=$(date +%s.%N)
  # Each rank under /usr/bin/time for its own peak RSS and CPU seconds; progress to the log.
  mpirun "${asroot[@]}" --oversubscribe --bind-to none -np "$ranks" \
    sh -c 'exec /usr/bin/time -f "%M %U %S" -o "$0.$OMPI_COMM_WORLD_RANK" "$@"' "$out/rss-$config" \
    "$pbdam" build --dem "$dem" --planet mars --levels "$levels" --threads "$threads" \
    --out "$dir" "${resume[@]}" >"$out/summary-$config.txt" 2>>"$log" || {
    status=$?
    say "$config: pbdam build failed (exit $status, $(date -u +%FT%TZ)); see $log"
    if [ "$(freeGb)" -lt 2 ]; then
      rm -rf "$dir"
      say "$config: the disk was nearly full; removed $dir (its checkpoint too)"
    fi
    exit "$status"
  }
  end=$(date +%s.%N)
  {
    awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }'
    for ((r = 0; r < ranks; r++)); do printf ' %s' "$(cat "$out/rss-$config.$r")"; done
    echo
  } >>"$times"
  "$pbdam" info "$dir" --json >"$out/info-$config.json"
  (cd "$dir" && sha256sum manifest.json face*.pbdam) >"$out/sha-$config.txt.tmp"
  mv "$out/sha-$config.txt.tmp" "$out/sha-$config.txt"
  du -sb "$dir" | cut -f1 >"$out/bytes-$config.txt"
  say "$config: done $(date -u +%FT%TZ)"
  if [ "$config" != "$last" ]; then rm -rf "$dir"; fi
done

# Summary: every segment of a configuration summed (a resumed build ran in several).
say ""
say "$(printf '%-6s %9s %9s %9s %9s %7s  %s' config wall_s cpu_s lattice_M/s source_M/s effic. 'peak RSS per rank (MB)')"
first=""
for config in $configs; do
  ranks=${config%x*}
  summary="$out/summary-$config.txt"
  lattice=$(awk '/^  input/ { print $6 }' "$summary")
  source=$(awk '/^  input/ { print $2 }' "$summary")
  read -r wall cpu rss < <(awk -v n="$ranks" '{
      w += $1
      for (r = 0; r < n; r++) { k = $(2 + 3 * r); if (k > m[r]) m[r] = k; c += $(3 + 3 * r) + $(4 + 3 * r) }
    } END { s = ""; for (r = 0; r < n; r++) s = s sprintf("%s%.0f", r ? "+" : "", m[r] / 1024)
            printf "%.1f %.1f %s\n", w, c, s }' "$out/times-$config.txt")
  [ -n "$first" ] || { first=$config; cpu1=$cpu; }
  say "$(awk -v c="$config" -v w="$wall" -v u="$cpu" -v l="$lattice" -v s="$source" -v u1="$cpu1" \
    -v r="$rss" 'BEGIN { printf "%-6s %9.1f %9.1f %9.3f %9.3f %7.2f  %s", c, w, u, l / w / 1e6,
                         s / w / 1e6, u1 / u, r }')"
done
same=yes
for config in $configs; do cmp -s "$out/sha-$first.txt" "$out/sha-$config.txt" || same=no; done
say "all configurations byte-identical (SHA-256 of every file): $same"
awk '/^  (lattice|input|patches|geometry|dataset)/' "$out/summary-$last.txt" | tee -a "$log"
awk '/^  geometry/ { c = $2; r = $6 } /^  dataset/ { d = $2 }
     END { printf "output: %.1f MB on disk; %.1f MB with uncompressed patches (compression %.2f)\n",
                  d, d - c + r, d / (d - c + r) }' "$out/summary-$last.txt" | tee -a "$log"
if [ "$verify" = 1 ] && [ ! -f "$out/verify-$last.txt" ]; then
  say "verify --dem on $out/out-$last ($(date -u +%FT%TZ))"
  /usr/bin/time -f "verify: %e s, peak RSS %M kB" "$pbdam" verify "$out/out-$last" --dem "$dem" \
    >"$out/verify-$last.txt.tmp" 2>&1 && mv "$out/verify-$last.txt.tmp" "$out/verify-$last.txt"
  tail -3 "$out/verify-$last.txt" | tee -a "$log"
fi

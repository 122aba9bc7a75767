#!/usr/bin/env bash
# Regenerates the example blocks of README.md from the current pbdam binary: every block between
# `<!-- example: NAME -->` and `<!-- /example -->` is replaced by a transcript ("$ command" lines
# and their real output) that this script makes by running the commands on the MOLA data in a
# scratch directory (two MOLA builds, the plain one and the same under a 2-rank mpirun).
#   scripts/readme_examples.sh [--check] [--pbdam PATH] [--mpirun PATH] [--readme FILE]
# Without --check it rewrites the README in place. With --check it writes the regenerated README
# to a scratch file and compares it with the committed one after masking what changes from run
# to run: numbers that carry units of time or size, and what is derived from them (rates,
# shares of a frame or of a size, frame-time percentiles, stall and page-fault counts), and the
# HTTP server's thread count (it follows the core count); runs of spaces count as one.
# Exit status: 0 same, 1 different (the diff is printed), 77 the MOLA data is missing (set
# PBDAM_DATA_DIR; CI=true makes that a failure).
# Transcripts show the commands as a user in a clone next to ../shared/data would type them:
# `pbdam` on PATH, the data under ../shared/data, and the server on port 8080 (it listens on a
# free port; the transcript names it 8080).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
pbdam=$root/build/release/tools/pbdam
mpirun=$(command -v mpirun || true)
readme=$root/README.md
check=0
while [ $# -gt 0 ]; do
  case $1 in
    --check) check=1 ;;
    --pbdam) pbdam=$2; shift ;;
    --mpirun) mpirun=$2; shift ;;
    --readme) readme=$2; shift ;;
    *) echo "usage: $0 [--check] [--pbdam PATH] [--mpirun PATH] [--readme FILE]" >&2; exit 2 ;;
  esac
  shift
done
pbdam=$(realpath "$pbdam")
readme=$(realpath "$readme")
data=$(realpath -m "${PBDAM_DATA_DIR:-$root/../shared/data}")
lbl=$data/mars/megt90n000cb.lbl
if [ ! -r "$lbl" ]; then
  echo "readme_examples: $lbl is missing (set PBDAM_DATA_DIR)"
  [ "${CI:-}" = "true" ] && exit 1
  exit 77
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/pbdam-readme.XXXXXX")
server=""
# shellcheck disable=SC2317  # called by the EXIT trap
cleanup() {
  if [ -n "$server" ]; then kill "$server" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
mkdir -p "$work/shared" "$work/repo" "$work/bin" "$work/out"
ln -s "$data" "$work/shared/data"
ln -s "$pbdam" "$work/bin/pbdam"
export PATH="$work/bin:$PATH"
# The examples show lavapipe's output whatever devices the machine has (pbdam's default is its
# best device).
export PBDAM_DEVICE=lavapipe
# The atmosphere's tables in a scratch cache: every run starts as a new machine would.
export PBDAM_CACHE_DIR="$work/cache"
cd "$work/repo"

# ex NAME CMD: appends "$ CMD" and CMD's output (stdout and stderr) to example NAME's transcript;
# CMD must succeed. The plain progress lines that build and verify print when stderr is not a
# terminal ("resample 10%"; on a terminal it is one bar) are left out: how many of them appear
# depends on timing. ex_fails: the same for a command that must fail (its exit status is shown).
run_cmd() {  # CMD OUTFILE
  local status=0
  bash -c "$1" > "$work/raw" 2>&1 || status=$?
  perl -ne 'print unless /^[a-z ]+ \d+%$/' "$work/raw" >> "$2"
  return $status
}
ex() {
  local name=$1 cmd=$2
  printf '$ %s\n' "$cmd" >> "$work/out/$name"
  if ! run_cmd "$cmd" "$work/out/$name"; then
    echo "readme_examples: '$cmd' failed:" >&2
    cat "$work/out/$name" >&2
    exit 1
  fi
}
ex_fails() {
  local name=$1 cmd=$2 status=0
  printf '$ %s\n' "$cmd" >> "$work/out/$name"
  run_cmd "$cmd" "$work/out/$name" || status=$?
  if [ "$status" -eq 0 ]; then
    echo "readme_examples: '$cmd' should have failed" >&2
    exit 1
  fi
  printf '$ echo $?\n%d\n' "$status" >> "$work/out/$name"
}
gap() { echo >> "$work/out/$1"; }

mola=../shared/data/mars/megt90n000cb.lbl
root_flag=""
if [ "$(id -u)" -eq 0 ]; then root_flag="--allow-run-as-root "; fi

ex dem-info "pbdam dem info $mola --at 18.65,226.2"
gap dem-info
ex dem-info "pbdam dem info ../shared/data/mars/megr90n000cb.img --raw-size 1440,720 \\
    --raw-type int16be --bounds -90,0,90,360 --json | head -5"
mkdir -p truncated
cp "$lbl" truncated/
head -c 1000000 "$data/mars/megt90n000cb.img" > truncated/megt90n000cb.img
gap dem-info
ex_fails dem-info "pbdam dem info truncated/megt90n000cb.lbl"

ex build "pbdam build --dem $mola --planet mars --out mars"

if [ -z "$mpirun" ]; then
  echo "readme_examples: mpirun not found (Debian's openmpi-bin)" >&2
  exit 1
fi
ln -s "$mpirun" "$work/bin/mpirun" 2>/dev/null || true
ex mpirun-build "mpirun ${root_flag}-np 2 pbdam build --dem $mola --planet mars \\
    --out mars-mpi --threads 1"
ex mpirun-build "for f in mars/*; do cmp \"\$f\" \"mars-mpi/\${f#mars/}\"; done && echo identical"

etopo=/usr/share/ferret-vis/data/etopo5.cdf
lux=../shared/data/geotiff/terra_elev_luxembourg.tif
ex inset "pbdam build --dem $etopo --planet earth --levels 8 --leaf-vertices 17 \\
    --inset $lux --out luxembourg --quiet"
ex inset "pbdam info luxembourg | head -5"
ex inset "pbdam verify luxembourg --dem $etopo --inset $lux"
ex inset "pbdam height luxembourg --at 49.6,6.13"

ex info "pbdam info mars"
ex verify "pbdam verify mars --dem $mola"

ex render "pbdam render mars --camera 18.4,-133.9,60e3,0,-20,0 --out olympus.png --stats stats.jsonl"
ex render "cat stats.jsonl"

ex height "pbdam height mars --at 18.4,-133.9"
gap height
ex height "pbdam height mars --at 18.4,-133.9 --json"

ex viewshed "pbdam query viewshed mars --at 18.4,-133.9,100 --radius-m 200000 --out olympus_vs.tif \\
    --check-dem $mola"
ex viewshed "gdalinfo olympus_vs.tif | grep -E '^(Size|Origin|Pixel Size)|NoData'"
ex viewshed "gdalsrsinfo -o proj4 olympus_vs.tif"

ex path "pbdam path great-circle --from 0,-60,3000e3 --to -8,-75,50e3 --duration 4 --fps 10 \\
    --dataset mars --out approach.csv"
ex path "head -3 approach.csv"

ex bench "pbdam bench mars --path approach.csv --out report --cold --quiet"
ex bench "ls report"

ex devices "pbdam devices"

# The server, on a free port; the transcript calls it 8080.
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])' 2>/dev/null ||
       echo $((20000 + RANDOM % 20000)))
# The server loads Mars's atmosphere tables at start: made here first (a scratch cache, not in the
# transcript), so the transcript shows a start that reads them.
pbdam render mars --camera 0,0,1e7 --atmosphere on --width 16 --height 16 --quiet \
  --out "$work/warm.png" 2>/dev/null
pbdam serve mars --port "$port" --workers 1 > serve.log 2>&1 &
server=$!
for _ in $(seq 600); do
  grep -q "http://" serve.log && break
  sleep 0.1
done
url="http://127.0.0.1:$port"
{
  printf '$ pbdam serve mars --workers 1 &\n'
  cat serve.log
} >> "$work/out/serve"
gap serve
ex serve "curl -s '$url/frame?lat=18.4&lon=-133.9&alt=60e3&pitch=-20&width=1280&height=720' \\
    -o olympus_s.png -D -"
ex serve "pbdam render mars --camera 18.4,-133.9,60e3,0,-20,0 --out olympus_r.png --quiet \\
    && cmp olympus_s.png olympus_r.png && echo identical"
gap serve
ex serve "curl -s '$url/frame?lat=18.4&lon=-133.9&alt=60e3&width=8000'; echo"
ex serve "curl -s '$url/frame?lat=18.4&lon=-133.9&alt=60e3&lattitude=3'; echo"
ex serve "curl -s -X DELETE '$url/stats'; echo"
ex serve "curl -s '$url/height?lat=18.4&lon=-133.9'; echo"
ex serve "curl -s '$url/stats'; echo"
kill -TERM "$server"
wait "$server" || true
server=""
printf '$ kill %%1\n' >> "$work/out/serve"
tail -n +2 serve.log >> "$work/out/serve"
sed -i -e "s/127\.0\.0\.1:$port/127.0.0.1:8080/g" -e 's/\r$//' "$work/out/serve"

# Splice the transcripts into the README's example blocks.
regenerated=$work/README.md
perl -e '
  my ($readme, $dir) = @ARGV;
  open(my $in, "<", $readme) or die "$readme: $!";
  my ($name, %used);
  while (my $line = <$in>) {
    if (defined $name) {
      next unless $line =~ /^<!-- \/example -->/;
      open(my $t, "<", "$dir/$name") or die "README example \"$name\" has no transcript\n";
      local $/; my $text = <$t>; $text =~ s/\n*\z/\n/;
      print "```\n$text```\n$line";
      $used{$name} = 1; undef $name;
    } elsif ($line =~ /^<!-- example: ([\w-]+) -->/) {
      $name = $1; print $line;
    } else { print $line; }
  }
  die "README example \"$name\" is not closed\n" if defined $name;
  opendir(my $d, $dir); for (sort readdir $d) {
    next if /^\./; warn "transcript \"$_\" has no README block\n" unless $used{$_};
  }
' "$readme" "$work/out" > "$regenerated"

if [ "$check" -eq 0 ]; then
  cp "$regenerated" "$readme"
  echo "readme_examples: regenerated the example blocks of $readme"
  exit 0
fi

mask() {
  perl -pe '
    my $n = qr/-?\d[\d,]*(?:\.\d+)?(?:e[+-]?\d+)?/;
    s/$n(\s?)(?:ns|µs|us|ms|s|min|h|B|bytes|kB|KB|KiB|MB|MiB|GB|GiB|TB|TiB)\b/#$1U/g;
    s/$n(\s?(?:[kMG]\s)?[a-z]*\/s)\b/#$1/g;
    s/$n(\s?fps)\b/#$1/g;
    s/$n%( of)/#%$1/g;
    s/\b(traversal|stalls|major faults|p50|p95|p99|max) $n/$1 #/g if /frame ms/;
    s/(\) )$n(; dataset pages)/$1#$2/g;
    s/("\w+_(?:ms|s|bytes)":\s?)$n/$1#/g;
    s/^(wrote \S+\.tif: \d+ x \d+ cells of \d+ m, ).*/$1#/;
    s/^(ray march over \S+ agrees on ).*/$1#/;
    s/("http_threads":)$n/$1#/g;
    s/^(X-Pbdam-[\w-]+-Ms: )$n/$1#/;
    s/ +/ /g;
  ' "$1"
}
if diff -u <(mask "$readme") <(mask "$regenerated"); then
  echo "readme_examples: the example blocks of $readme match this pbdam"
  exit 0
fi
echo "readme_examples: the example blocks above differ from what this pbdam prints (after" \
     "masking times and sizes); regenerate them with scripts/readme_examples.sh" >&2
exit 1

#!/usr/bin/env bash
# Scaling from one thread to two: the same render (same seed, same samples or mutations per
# pixel, so the same work and the same image) on `--threads 1` and `--threads 2`, runs
# alternating, and the ratio of the median render times (issue 17 asks for at least 1.9×).
#
#   scripts/thread-scaling.sh [SCENES] [ALGOS] [ROUNDS]
#   scripts/thread-scaling.sh "cornell door" "mmlt cmlt" 3
#
# Defaults: SCENES = veach-bidir (../shared/scenes) and the built-ins cornell caustic door ring
# pool; ALGOS = pt bdpt pssmlt mmlt mlt cmlt memlt; ROUNDS = 2; RESOLUTION = 512x288;
# MAX_DEPTH = 7; SPP = 4 (PT: 4× that). Every method runs with its defaults. BIN names a binary
# to use instead of building this checkout. Prints, per scene and algorithm, the median render
# time on one and on two threads and their ratio, then the same from the fastest run of each
# (other work on a shared machine only adds time, and a two-thread run needs both cores free, so
# it is hit more often); final lines give the geometric means of both ratios.
#
# CEILING=1 adds, per round, two one-thread renders run at once as separate processes: each does
# the whole work, so `2 × (one thread alone) / (the slower of the pair)` is what this machine gives
# two workers that share nothing (its "ceiling"), and the program's scaling over it is the share
# of the machine's two cores that the two-thread render turns into speed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
scenes=${1:-"$root/../shared/scenes/veach-bidir/scene.pbrt cornell caustic door ring pool"}
algos=${2:-"pt bdpt pssmlt mmlt mlt cmlt memlt"}
rounds=${3:-2}
res=${RESOLUTION:-512x288} depth=${MAX_DEPTH:-7} spp=${SPP:-4}
if [[ -z ${BIN:-} ]]; then
  (cd "$root" && cargo build --release --quiet)
  BIN=$root/target/release/charted
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# One run: prints the render's seconds (TAG names its output, for runs at the same time).
run() {
  local scene=$1 algo=$2 threads=$3 tag=${4:-a} n=$spp
  [[ $algo == pt ]] && n=$((4 * spp))
  "$BIN" render "$scene" --algo "$algo" --spp "$n" --resolution "$res" --max-depth "$depth" \
    --threads "$threads" -o "$out/img-$tag.exr" > "$out/log-$tag" 2>&1 ||
    { cat "$out/log-$tag" >&2; return 1; }
  sed -nE 's/^time .*render ([0-9.]+) s.*/\1/p' "$out/log-$tag"
}

# Two one-thread runs at once: prints the slower one's seconds.
run_pair() {
  run "$1" "$2" 1 a > "$out/pair-a" &
  local a=$!
  run "$1" "$2" 1 b > "$out/pair-b"
  wait "$a"
  cat "$out/pair-a" "$out/pair-b" | sort -g | tail -n 1
}

# shellcheck source=timing-lib.sh
source "$root/scripts/timing-lib.sh"

ceiling=${CEILING:-0}
printf '%-12s %-7s %9s %9s %8s %9s %9s %8s' scene algo "1 thread" "2 threads" scaling \
  "1 (min)" "2 (min)" "(min)"
[[ $ceiling == 1 ]] && printf ' %9s %8s %10s' "1+1 at once" ceiling "of ceiling"
printf '\n'
logsum=0 logmin=0 logceil=0 logshare=0 count=0
for scene in $scenes; do
  name=$(scene_name "$scene")
  for algo in $algos; do
    : > "$out/one" && : > "$out/two" && : > "$out/pair"
    for _ in $(seq 1 "$rounds"); do
      run "$scene" "$algo" 1 >> "$out/one"
      run "$scene" "$algo" 2 >> "$out/two"
      [[ $ceiling == 1 ]] && run_pair "$scene" "$algo" >> "$out/pair"
    done
    t1=$(median < "$out/one") t2=$(median < "$out/two")
    m1=$(minimum < "$out/one") m2=$(minimum < "$out/two")
    ratio=$(awk -v a="$t1" -v b="$t2" 'BEGIN { printf "%.3f", a / b }')
    rmin=$(awk -v a="$m1" -v b="$m2" 'BEGIN { printf "%.3f", a / b }')
    printf '%-12s %-7s %9.2f %9.2f %7.2f× %9.2f %9.2f %7.2f×' "$name" "$algo" "$t1" "$t2" \
      "$ratio" "$m1" "$m2" "$rmin"
    if [[ $ceiling == 1 ]]; then
      tp=$(median < "$out/pair")
      ceil=$(awk -v a="$t1" -v b="$tp" 'BEGIN { printf "%.3f", 2 * a / b }')
      share=$(awk -v r="$ratio" -v c="$ceil" 'BEGIN { printf "%.3f", r / c }')
      printf ' %9.2f %7.2f× %9.1f%%' "$tp" "$ceil" "$(awk -v s="$share" 'BEGIN { print 100 * s }')"
      logceil=$(add_log "$logceil" "$ceil")
      logshare=$(add_log "$logshare" "$share")
    fi
    printf '\n'
    logsum=$(add_log "$logsum" "$ratio")
    logmin=$(add_log "$logmin" "$rmin")
    count=$((count + 1))
  done
done
echo "geometric mean scaling over $count runs: $(geomean "$logsum" "$count")× (medians)"
echo "geometric mean scaling over $count runs: $(geomean "$logmin" "$count")× (fastest runs)"
if [[ $ceiling == 1 ]]; then
  echo "geometric mean ceiling (two one-thread runs at once): $(geomean "$logceil" "$count")×"
  share=$(awk -v g="$(geomean "$logshare" "$count")" 'BEGIN { printf "%.1f", 100 * g }')
  echo "geometric mean share of the ceiling: $share%"
fi

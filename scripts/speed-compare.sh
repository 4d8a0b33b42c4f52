#!/usr/bin/env bash
# Throughput and peak memory of this checkout's build against an older revision, side by side on
# one machine, runs alternating (the only kind of speed claim this project makes: absolute times
# drift by ±15% on shared machines). Each run renders a fixed amount of work (same seed, same
# samples or mutations per pixel), so the ratio of render times is the ratio of throughputs.
#
#   scripts/speed-compare.sh REV [SCENES] [ALGOS] [ROUNDS]
#   scripts/speed-compare.sh e7dad17
#   scripts/speed-compare.sh e7dad17 "cornell door" "bdpt mmlt" 5
#
# Defaults: SCENES = veach-bidir (../shared/scenes), the caustic as a pbrt file
# (examples/scenes/caustic.pbrt: the built-in's light faced up before issue 17, so builds on either
# side of the fix would render different built-ins) and the built-ins cornell door ring pool; ALGOS = pt bdpt pssmlt mmlt mlt cmlt memlt mept; ROUNDS = 3; RESOLUTION = 512x288;
# MAX_DEPTH = 7; SPP = 4 (PT: 4× that). REV is built in a git worktree (scripts/build-rev.sh:
# ../charted-REV, or OLD_DIR); NEW_BIN and OLD_BIN name binaries to use instead of building them.
# Both builds run the same estimators: roulette, the Metropolis methods' direct pass and the Sobol
# sampler, where a build has them, are off (below; their gains are measured at equal time).
# Prints, per scene and algorithm, the median render time of each build, the speed-up
# (old time / new time, > 1 is faster) and the peak resident memory of each build; then per
# method and per scene the geometric mean of the speed-ups and how many cells reach GOAL (default
# 2.5×, issue 17's); a final line gives the geometric mean of all the speed-ups.
set -euo pipefail
rev=$1
root=$(cd "$(dirname "$0")/.." && pwd)
scenes=${2:-"$root/../shared/scenes/veach-bidir/scene.pbrt cornell $root/examples/scenes/caustic.pbrt door ring pool"}
algos=${3:-"pt bdpt pssmlt mmlt mlt cmlt memlt mept"}
rounds=${4:-3}
res=${RESOLUTION:-512x288} depth=${MAX_DEPTH:-7} spp=${SPP:-4}
cd "$root"
[[ -z ${NEW_BIN:-} ]] && cargo build --release --quiet
new_bin=${NEW_BIN:-"$root/target/release/charted"} old_bin=${OLD_BIN:-$(scripts/build-rev.sh "$rev")}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# Equal work: builds that know --roulette (on by default since issue 17) render PT, BDPT and PSSMLT
# with it off, as builds before it did; roulette's gain is the estimator's, measured at equal time
# (scripts/equal-time-variance.sh), not a faster sample.
knows_roulette() { "$1" render --help 2>/dev/null | grep -q -- '--roulette <'; }
old_rr=() new_rr=()
knows_roulette "$old_bin" && old_rr=(--roulette 0)
knows_roulette "$new_bin" && new_rr=(--roulette 0)
# Likewise the direct-lighting pass of the Metropolis methods (default since issue 17): off in
# builds that know it, so the chains do the same work in both builds (its gain is measured at
# equal time).
knows_direct() { "$1" render --help 2>/dev/null | grep -q -- '--direct-samples <'; }
old_direct=() new_direct=()
knows_direct "$old_bin" && old_direct=(--direct-samples 0)
knows_direct "$new_bin" && new_direct=(--direct-samples 0)

# Likewise the Owen-scrambled Sobol sampler of the pass-based methods (default since issue 17; an
# estimator change like the two above, measured at equal time): builds that know --sampler draw
# independent numbers, as builds before it did. SOBOL=1 keeps each build's default sampler (the
# protocol of this script before `5693606`; Sobol points cost PT 4–6% and BDPT 1–4% per sample).
knows_sampler() { "$1" render --help 2>/dev/null | grep -q -- '--sampler <'; }
old_sampler=() new_sampler=()
if [[ ${SOBOL:-0} != 1 ]]; then
  knows_sampler "$old_bin" && old_sampler=(--sampler independent)
  knows_sampler "$new_bin" && new_sampler=(--sampler independent)
fi

# One run: prints "render-seconds peak-kilobytes".
run() {
  local bin=$1 scene=$2 algo=$3 n=$spp extra=()
  [[ $algo == pt ]] && n=$((4 * spp))
  if [[ $algo == pt || $algo == bdpt || $algo == pssmlt ]]; then
    if [[ $bin == "$old_bin" ]]; then extra=("${old_rr[@]}"); else extra=("${new_rr[@]}"); fi
  fi
  if [[ $algo == pt || $algo == bdpt || $algo == erpt || $algo == mept ]]; then
    if [[ $bin == "$old_bin" ]]; then extra+=("${old_sampler[@]}"); else extra+=("${new_sampler[@]}"); fi
  fi
  if [[ $algo != pt && $algo != bdpt ]]; then
    if [[ $bin == "$old_bin" ]]; then extra+=("${old_direct[@]}"); else extra+=("${new_direct[@]}"); fi
  fi
  /usr/bin/time -f '%M' -o "$out/mem" "$bin" render "$scene" --algo "$algo" --spp "$n" \
    --resolution "$res" --max-depth "$depth" "${extra[@]}" -o "$out/img.exr" > "$out/log" 2>&1 ||
    { cat "$out/log" >&2; return 1; }
  local t
  t=$(sed -nE 's/^time .*render ([0-9.]+) s.*/\1/p' "$out/log")
  echo "$t $(cat "$out/mem")"
}

# shellcheck source=timing-lib.sh
source "$root/scripts/timing-lib.sh"

printf '%-12s %-7s %9s %9s %8s %10s %10s\n' scene algo "old s" "new s" speed-up "old MB" "new MB"
logsum=0 count=0
for scene in $scenes; do
  name=$(scene_name "$scene")
  for algo in $algos; do
    : > "$out/old" && : > "$out/new"
    # The order alternates by round (old-new, new-old, ...): a run that always follows the
    # other build's would carry whatever that run leaves behind (caches, the CPU's clock).
    for r in $(seq 1 "$rounds"); do
      if ((r % 2)); then
        run "$old_bin" "$scene" "$algo" >> "$out/old"
        run "$new_bin" "$scene" "$algo" >> "$out/new"
      else
        run "$new_bin" "$scene" "$algo" >> "$out/new"
        run "$old_bin" "$scene" "$algo" >> "$out/old"
      fi
    done
    to=$(cut -d' ' -f1 "$out/old" | median) tn=$(cut -d' ' -f1 "$out/new" | median)
    mo=$(cut -d' ' -f2 "$out/old" | sort -g | tail -1) mn=$(cut -d' ' -f2 "$out/new" | sort -g | tail -1)
    ratio=$(awk -v a="$to" -v b="$tn" 'BEGIN { printf "%.3f", a / b }')
    printf '%-12s %-7s %9.2f %9.2f %7.2f× %10.1f %10.1f\n' "$name" "$algo" "$to" "$tn" "$ratio" \
      "$(awk -v m="$mo" 'BEGIN { print m / 1024 }')" "$(awk -v m="$mn" 'BEGIN { print m / 1024 }')"
    echo "$name $algo $ratio" >> "$out/ratios"
    logsum=$(add_log "$logsum" "$ratio")
    count=$((count + 1))
  done
done
# Per method and per scene: the geometric mean of their cells, and the cells at or above GOAL
# (default 2.5, issue 17's).
awk -v goal="${GOAL:-2.5}" '
  { la[$2] += log($3); na[$2]++; ls[$1] += log($3); ns[$1]++; if ($3 >= goal) { met++; hit[$2]++ } }
  !($2 in seen_a) { seen_a[$2] = 1; order_a[++ka] = $2 }
  !($1 in seen_s) { seen_s[$1] = 1; order_s[++ks] = $1 }
  END {
    for (i = 1; i <= ka; i++) { a = order_a[i]
      printf "method %-7s geometric mean %6.3f× over %d scenes, %d at or above %.2f×\n", a, exp(la[a] / na[a]), na[a], hit[a] + 0, goal }
    for (i = 1; i <= ks; i++) { c = order_s[i]
      printf "scene  %-12s geometric mean %6.3f× over %d methods\n", c, exp(ls[c] / ns[c]), ns[c] }
    printf "cells at or above %.2f×: %d of %d\n", goal, met + 0, NR
  }' "$out/ratios"
echo "geometric mean speed-up over $count runs: $(geomean "$logsum" "$count")×"

#!/usr/bin/env bash
# Equal-time error of this checkout's build against an older revision's, both with their own
# defaults, reference-free (scripts/equal-time-variance.sh: PAIRS pairs of seeds per build, the
# RMSE from the pairs' differences). Per scene and algorithm the two builds run one after the
# other, so the machine's drift falls on both alike; prints the RMSE of each, their ratio (this
# build / the old one, < 1 is better), the ratio of the median pairs' RMSEs (robust to a rare
# firefly; with PAIRS=2 it is the mean's), and the mutations or samples per pixel of each, then
# the geometric mean of the ratios.
#
#   scripts/equal-time-builds.sh REV TIME "ALGOS" "SCENES"
#   scripts/equal-time-builds.sh e7dad17 60s "mmlt mlt" "door examples/scenes/caustic.pbrt veach-bidir"
#
# Against a build from before issue 17's fix of the built-in caustic (its light faced up), name the
# caustic by its pbrt file, which both builds render alike.
#
# REV is built in a git worktree (scripts/build-rev.sh); NEW_BIN and OLD_BIN name binaries to use
# instead of building them (so the checkout can change while a measurement runs). NEW_SETTING
# adds `charted render` options to this build's renders only (e.g. NEW_SETTING="--roulette-walks
# both": a setting against the old build's defaults). Renders stay in OUT (default
# out/equal-time-builds). Resolution, depth, PAIRS and SEED_BASE (other seeds, for a run independent
# of an earlier one) as scripts/equal-time-variance.sh.
set -euo pipefail
rev=$1 time=$2 algos=$3 scenes=$4
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
if [[ -z ${NEW_BIN:-} ]]; then
  cargo build --release --quiet
  NEW_BIN=$root/target/release/charted
fi
OLD_BIN=${OLD_BIN:-$(scripts/build-rev.sh "$rev")}
out=${OUT:-out/equal-time-builds}
printf '%-12s %-7s %11s %11s %7s %7s %9s %9s\n' scene algo "new RMSE" "old RMSE" ratio median "new spp" "old spp"
logsum=0 medsum=0 count=0
for scene in $scenes; do
  for algo in $algos; do
    declare -A rmse spp med
    for build in new old; do
      bin=$NEW_BIN setting=${NEW_SETTING:-}
      [[ $build == old ]] && bin=$OLD_BIN setting=
      line=$(BIN=$bin scripts/equal-time-variance.sh "$out/$algo-$build" "$time" "$algo" "$scene" "$setting" | tail -1)
      # Columns: scene, the setting (one or more words), spp, RMSE, ratio, median RMSE, ratio.
      spp[$build]=$(awk '{ print $(NF - 4) }' <<< "$line")
      rmse[$build]=$(awk '{ print $(NF - 3) }' <<< "$line")
      med[$build]=$(awk '{ print $(NF - 1) }' <<< "$line")
    done
    ratio=$(awk -v a="${rmse[new]}" -v b="${rmse[old]}" 'BEGIN { printf "%.3f", a / b }')
    median=$(awk -v a="${med[new]}" -v b="${med[old]}" 'BEGIN { printf "%.3f", a / b }')
    printf '%-12s %-7s %11s %11s %6s× %6s× %9s %9s\n' "$scene" "$algo" "${rmse[new]}" "${rmse[old]}" \
      "$ratio" "$median" "${spp[new]}" "${spp[old]}"
    logsum=$(awk -v s="$logsum" -v r="$ratio" 'BEGIN { print s + log(r) }')
    medsum=$(awk -v s="$medsum" -v r="$median" 'BEGIN { print s + log(r) }')
    count=$((count + 1))
  done
done
awk -v s="$logsum" -v m="$medsum" -v n="$count" \
  'BEGIN { printf "geometric mean RMSE ratio over %d cells: %.3f× (median pairs: %.3f×)\n", n, exp(s / n), exp(m / n) }'

#!/usr/bin/env bash
# Equal-time error of an unbiased algorithm under several settings, measured without a reference:
# two renders with different seeds differ by noise alone, so E[MSE(a₁, a₂)] = 2 Var and
# √(MSE(a₁, a₂)/2) is the RMSE of one render against the exact image (no reference noise to
# subtract). Each setting renders PAIRS pairs of seeds; the script prints the samples per pixel
# of the first render, the RMSE from the mean MSE of the pairs and its ratio to the first
# setting, and the same from the median pair (robust to a rare firefly, which can dominate a
# pair's MSE on scenes such as veach-bidir).
#
#   scripts/equal-time-variance.sh OUT TIME ALGO "SCENES" "SETTING" ["SETTING" ...]
#   scripts/equal-time-variance.sh out/sampler 20s bdpt "cornell door" "--sampler independent" "--sampler sobol"
#
# A setting is a string of `charted render` options (may be empty: ""). SCENES are built-in names
# or pbrt files; `veach-bidir` names ../shared/scenes/veach-bidir/scene.pbrt. veach-bidir renders
# at 256×144 with maximum depth 7, the built-ins at 256×256 with maximum depth 8 (RESOLUTION and
# MAX_DEPTH override both). PAIRS defaults to 2 (seeds 1–4); SEED_BASE shifts the seeds (SEED_BASE=6:
# seeds 7–10), for a run independent of an earlier one. BIN names a binary to use instead of
# building this checkout.
set -euo pipefail
cd "$(dirname "$0")/.."
out=$1 time=$2 algo=$3 scenes=$4
shift 4
pairs=${PAIRS:-2} seed_base=${SEED_BASE:-0}
mkdir -p "$out"
if [[ -z ${BIN:-} ]]; then
  cargo build --release --quiet
  BIN=target/release/charted
fi
printf '%-12s %-28s %8s %11s %7s %13s %7s\n' scene setting spp RMSE ratio "median RMSE" ratio
for scene in $scenes; do
  name=$scene res=256x256 depth=8
  if [[ $scene == veach-bidir ]]; then
    scene=../shared/scenes/veach-bidir/scene.pbrt res=256x144 depth=7
  elif [[ -f $scene ]]; then
    name=$(basename "$scene" .pbrt)
  fi
  res=${RESOLUTION:-$res} depth=${MAX_DEPTH:-$depth}
  base=
  k=0
  for setting in "$@"; do
    k=$((k + 1))
    spp= sum=0 mses=()
    for pair in $(seq 1 "$pairs"); do
      first=$((seed_base + 2 * pair - 1))
      for seed in $first $((first + 1)); do
        # shellcheck disable=SC2086 # a setting is a list of options
        log=$("$BIN" render "$scene" --algo "$algo" --time "$time" --seed "$seed" \
          --resolution "$res" --max-depth "$depth" $setting -o "$out/$name-$k-$seed.exr" 2>&1)
        [[ -z $spp ]] && spp=$(sed -n 's/^samples *\([0-9.]*\) spp.*/\1/p' <<< "$log")
      done
      mse=$("$BIN" diff "$out/$name-$k-$first.exr" "$out/$name-$k-$((first + 1)).exr" |
        sed -n 's/.*  MSE \([^ ]*\) .*/\1/p')
      sum=$(awk -v s="$sum" -v m="$mse" 'BEGIN { print s + m }')
      mses+=("$mse")
    done
    rmse=$(awk -v s="$sum" -v n="$pairs" 'BEGIN { printf "%.4e", sqrt(s / n / 2) }')
    median=$(printf '%s\n' "${mses[@]}" | sort -g |
      awk '{ v[NR] = $1 } END { m = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2; printf "%.4e", sqrt(m / 2) }')
    [[ -z $base ]] && base=$rmse base_median=$median
    ratio=$(awk -v r="$rmse" -v b="$base" 'BEGIN { printf "%.2f", r / b }')
    ratio_median=$(awk -v r="$median" -v b="$base_median" 'BEGIN { printf "%.2f", r / b }')
    printf '%-12s %-28s %8s %11s %6s× %13s %6s×\n' "$name" "${setting:-(defaults)}" "$spp" "$rmse" \
      "$ratio" "$median" "$ratio_median"
  done
done

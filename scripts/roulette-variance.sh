#!/usr/bin/env bash
# Equal-time error of BDPT with Russian roulette in the subpath walks from several vertices
# (`--roulette`), measured without a reference: for an unbiased method two renders with
# different seeds differ by noise alone, so E[MSE(a₁, a₂)] = 2 Var and √(MSE(a₁, a₂)/2) is the
# RMSE of one render against the exact image (no reference noise to subtract). Prints samples
# per pixel, that RMSE, and its ratio to roulette off (the first setting) per scene.
#
#   scripts/roulette-variance.sh [out-dir] [time] [scenes] [settings]
#   scripts/roulette-variance.sh out/roulette 20s "cornell door" "0 1 3"
#
# Defaults: 20 s per render, veach-bidir (../shared/scenes; 256×144, max depth 7) and the
# built-ins cornell caustic door ring pool (256×256, max depth 8), settings "0 1 2 4"
# (0 = off), seeds 1 and 2.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/roulette}
time=${2:-20s}
scenes=${3:-"../shared/scenes/veach-bidir/scene.pbrt cornell caustic door ring pool"}
settings=${4:-"0 1 2 4"}
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/charted
printf '%-12s %-8s %14s %12s %8s\n' scene roulette "spp (seeds)" RMSE ratio
for scene in $scenes; do
  name=$(basename "$(dirname "$scene")")
  [[ -f $scene ]] || name=$scene
  res=256x256 depth=8
  [[ $name == veach-bidir ]] && res=256x144 depth=7
  base=
  for r in $settings; do
    spp=()
    for seed in 1 2; do
      img=$out/$name-r$r-s$seed.exr
      log=$($bin render "$scene" --algo bdpt --roulette "$r" --time "$time" --seed "$seed" \
        --resolution $res --max-depth $depth -o "$img" 2>&1)
      spp+=("$(sed -n 's/^samples *\([0-9.]*\) spp.*/\1/p' <<< "$log")")
    done
    mse=$($bin diff "$out/$name-r$r-s1.exr" "$out/$name-r$r-s2.exr" | sed -n 's/.*  MSE \([^ ]*\) .*/\1/p')
    rmse=$(python3 -c "import math; print(f'{math.sqrt($mse / 2):.4e}')")
    [[ -z $base ]] && base=$rmse
    ratio=$(python3 -c "print(f'{$rmse / $base:.2f}')")
    printf '%-12s %-8s %14s %12s %7s×\n' "$name" "$r" "${spp[0]}/${spp[1]}" "$rmse" "$ratio"
  done
done

#!/usr/bin/env bash
# Russian roulette on shadow rays at equal time: renders each scene with BDPT (or PT) for the same
# time with --shadow-roulette 0 (off), 0.05 and 0.2 and prints samples per pixel and the errors
# against a long reference of the same algorithm family (BDPT, made when missing).
#
#   scripts/shadow-roulette-compare.sh [out-dir] [time] [ref-time] [scenes] [algos]
#   scripts/shadow-roulette-compare.sh out/shadow 20s 100s "cornell door" "bdpt pt"
#
# Defaults: 20 s per render, 100 s references, 256×256 (veach-bidir 256×144), max depth 8
# (veach-bidir 7), seeds 1 and 2.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/shadow-roulette}
time=${2:-20s}
ref_time=${3:-100s}
scenes=${4:-"cornell door ../shared/scenes/veach-bidir/scene.pbrt"}
algos=${5:-"bdpt pt"}
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/charted
printf '%-12s %-5s %-5s %-4s %9s %12s %12s %10s\n' scene algo frac seed spp RMSE MAE E_rms
for scene in $scenes; do
  name=$(basename "$(dirname "$scene")")
  [[ -f $scene ]] || name=$scene
  res=256x256 depth=8
  [[ $name == veach-bidir ]] && res=256x144 depth=7
  ref=$out/$name-ref.exr
  if [[ ! -f $ref ]]; then
    $bin reference "$scene" --resolution $res --max-depth $depth --time "$ref_time" -o "$ref" \
      > "$out/$name-ref.log" 2>&1
  fi
  for algo in $algos; do
    for seed in 1 2; do
      for frac in 0 0.05 0.2; do
        img=$out/$name-$algo-$frac-$seed.exr
        $bin render "$scene" --algo "$algo" --resolution $res --max-depth $depth --time "$time" \
          --seed $seed --shadow-roulette $frac -o "$img" > "$out/log" 2>&1
        spp=$(sed -nE 's/^samples +([0-9.]+) spp.*/\1/p' "$out/log")
        d=$($bin diff "$img" "$ref")
        d=${d%%$'\n'*}
        rmse=$(grep -oP 'RMSE \K[0-9.e+-]+' <<<"$d")
        mae=$(grep -oP 'MAE \K[0-9.e+-]+' <<<"$d")
        erms=$(grep -oP 'E_rms \K[0-9.e+-]+' <<<"$d")
        printf '%-12s %-5s %-5s %-4s %9s %12s %12s %10s\n' "$name" "$algo" "$frac" "$seed" "$spp" \
          "$rmse" "$mae" "$erms"
      done
    done
  done
done

#!/usr/bin/env bash
# Equal-time error of BDPT with Russian roulette in the subpath walks from several vertices
# (`--roulette`), measured without a reference (scripts/equal-time-variance.sh): prints samples
# per pixel, the RMSE against the exact image, and its ratio to the first setting, per scene.
#
#   scripts/roulette-variance.sh [out-dir] [time] [scenes] [settings]
#   scripts/roulette-variance.sh out/roulette 20s "cornell door" "0 1 3"
#
# Defaults: 20 s per render, veach-bidir (../shared/scenes; 256×144, max depth 7) and the
# built-ins cornell caustic door ring pool (256×256, max depth 8), settings "0 1 2 4"
# (0 = off). WALKS (default both; the renderer's own default is light) chooses which walks stop.
set -euo pipefail
out=${1:-out/roulette}
time=${2:-20s}
scenes=${3:-"veach-bidir cornell caustic door ring pool"}
settings=()
for r in ${4:-"0 1 2 4"}; do
  if [[ $r == 0 ]]; then settings+=("--roulette 0"); else settings+=("--roulette $r --roulette-walks ${WALKS:-both}"); fi
done
exec "$(dirname "$0")/equal-time-variance.sh" "$out" "$time" bdpt "$scenes" "${settings[@]}"

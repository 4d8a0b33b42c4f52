#!/usr/bin/env bash
# The Table 1 of Fan, Chenney & Lai 2005 on our three scenes: standard photon mapping (pm) and
# Metropolis photon sampling (mps; on `box` also with the shipped user paths) with the same final
# gather (4 spp, 16 gather rays, k = 60), photon budgets set for about equal total time, each
# against a long BDPT reference; E_rms is the RMS over pixels of (I − I_ref)/I_ref on luminance.
#
#   scripts/mps-compare.sh [out-dir]        (references: 200 s of BDPT each, made when missing)
#
# Prints one row per scene and method: resolution, t_B, t_map, t_FG, total, photons, E_rms.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/mps-compare}
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/charted
spp=4

# scene, pm photon paths per map, mps mutations per pixel (set for about equal total time on a
# 2-core machine in November 2026, with the maximum radii from the maps' density)
runs=(
  "rooms 1000000 20"
  "lantern 2000000 40"
  "box 200000 64"
)

field() { grep -oP "$1" "$2" | head -1; }

row() { # scene algo log exr
  local scene=$1 algo=$2 log=$3 exr=$4
  local render tb tmap photons_g photons_c erms res
  # The maps are built before the final gather starts: `render` is t_FG.
  render=$(field 'render \K[0-9.]+' "$log")
  res=$(field 'scene +\S+ \(\K[0-9×]+' "$log")
  if [[ $algo == pm ]]; then
    tb=0
    tmap=$(field 't_map \K[0-9.]+' "$log")
  else
    tb=$(field 't_B \K[0-9.]+' "$log")
    tmap=$(field 't_map \K[0-9.]+' "$log")
  fi
  photons_g=$(field 'photons +global \K[0-9]+' "$log")
  photons_c=$(field 'photons +global [0-9]+, caustic \K[0-9]+' "$log")
  erms=$($bin diff "$exr" "$out/$scene-ref.exr" | grep -oP 'E_rms \K[0-9.]+')
  local total
  total=$(echo "$tb + $tmap + $render" | bc -l)
  printf "| %-8s | %-7s | %9s | %6.1f | %6.1f | %6.1f | %6.1f | %8d | %7s |\n" \
    "$scene" "$algo" "$res" "$tb" "$tmap" "$render" "$total" "$((photons_g + photons_c))" "$erms"
}

echo "| scene    | method  | res       | t_B s  | t_map s| t_FG s | total s| photons  | E_rms   |"
echo "|---|---|---|---|---|---|---|---|---|"
for r in "${runs[@]}"; do
  read -r scene paths mutations <<<"$r"
  if [[ ! -f $out/$scene-ref.exr ]]; then
    $bin reference "$scene" --time 200s -o "$out/$scene-ref.exr" >"$out/$scene-ref.log" 2>&1
  fi
  $bin render "$scene" --algo pm --spp $spp --global-photons "$paths" --caustic-photons "$paths" \
    -o "$out/$scene-pm.exr" >"$out/$scene-pm.log" 2>&1
  row "$scene" pm "$out/$scene-pm.log" "$out/$scene-pm.exr"
  $bin render "$scene" --algo mps --spp $spp --photon-mutations "$mutations" \
    -o "$out/$scene-mps.exr" >"$out/$scene-mps.log" 2>&1
  row "$scene" mps "$out/$scene-mps.log" "$out/$scene-mps.exr"
  if [[ $scene == box ]]; then
    $bin render box --algo mps --spp $spp --photon-mutations "$mutations" \
      --user-paths examples/box.user-paths -o "$out/box-mps-up.exr" >"$out/box-mps-up.log" 2>&1
    row box mps+UP "$out/box-mps-up.log" "$out/box-mps-up.exr"
  fi
done

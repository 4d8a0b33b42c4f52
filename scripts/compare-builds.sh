#!/usr/bin/env bash
# Equal-time comparison of this checkout's build against an older revision, side by side on one
# machine (the only kind of speed claim this project makes: absolute times drift by ±15% here).
#
#   scripts/compare-builds.sh REV "SCENES" ALGOS SECONDS [ROUNDS] [-- extra compare options]
#   scripts/compare-builds.sh 3d5fea6 "cornell examples/scenes/caustic.pbrt door ring" mlt,cmlt 60 1
#
# Builds REV in a git worktree (../charted-REV, or OLD_DIR), renders a BDPT reference per scene with this
# build (REFTIME seconds, default 480, kept in out/ref/), then runs `charted compare` with both
# builds, alternating, ROUNDS times (default 1), at 256×256 (RESOLUTION to change), and prints the
# final RMSE of every algorithm, build and round. Outputs stay in out/builds/. NEW_BIN names a
# copy of this build's binary to use instead (so the checkout can change while a measurement runs).
set -euo pipefail
rev=$1 scenes=$2 algos=$3 secs=$4 rounds=${5:-1}
shift $(( $# < 5 ? $# : 5 ))
[[ ${1:-} == -- ]] && shift
extra=("$@")
root=$(cd "$(dirname "$0")/.." && pwd)
res=${RESOLUTION:-256x256}
reftime=${REFTIME:-480}
cd "$root"
[[ -z ${NEW_BIN:-} ]] && cargo build --release --quiet
new_bin=${NEW_BIN:-"$root/target/release/charted"} old_bin=$(scripts/build-rev.sh "$rev")
mkdir -p out/ref out/builds
for scene in $scenes; do
  ref="out/ref/$scene.exr"
  if [[ ! -f $ref ]]; then
    "$new_bin" reference "$scene" --time "${reftime}s" --resolution "$res" -o "$ref" > /dev/null
  fi
  for round in $(seq 1 "$rounds"); do
    for build in new old; do
      bin=$new_bin; [[ $build == old ]] && bin=$old_bin
      dir="out/builds/$scene-$build-$round"
      "$bin" compare "$scene" --algos "$algos" --time "${secs}s" --resolution "$res" \
        --reference "$ref" -o "$dir" "${extra[@]}" > "$dir.log" 2>&1 || { cat "$dir.log"; exit 1; }
      awk -F, -v s="$scene" -v b="$build" -v r="$round" 'NR > 1 { last[$1] = $0 }
        END { for (a in last) { split(last[a], f, ","); printf "%-8s %-7s %-4s round %s: %5s s, spp %6s, RMSE %s\n", s, a, b, r, f[3], f[4], f[5] } }' \
        "$dir/errors.csv"
    done
  done
done

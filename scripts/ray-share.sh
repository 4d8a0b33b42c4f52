#!/usr/bin/env bash
# Where a render's time goes, and what that allows: the share of its samples spent in the BVH's
# ray queries (traversal, primitive tests, building the hit's surface point) from a sampling
# profile, and the largest speed-up any work outside them could still give (Amdahl's law: the
# render cannot run faster than its ray queries alone, 1 / share).
#
#   scripts/ray-share.sh [SCENE] [ALGOS]
#   scripts/ray-share.sh ../shared/scenes/veach-bidir/scene.pbrt "bdpt mmlt mlt"
#
# Defaults: SCENE = ../shared/scenes/veach-bidir/scene.pbrt; ALGOS = pt bdpt pssmlt mmlt mlt cmlt;
# RESOLUTION = 384x216, MAX_DEPTH = 7, SPP = 4 (PT: 4× that), one thread (the profile of one
# thread is the profile of each). BDPT, PT and PSSMLT run with `--roulette 0`, the work that
# `scripts/speed-compare.sh` compares. BIN names a binary to use instead of building this
# checkout. Needs `perf` (Debian: `apt-get install linux-perf`).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
scene=${1:-"$root/../shared/scenes/veach-bidir/scene.pbrt"}
algos=${2:-"pt bdpt pssmlt mmlt mlt cmlt"}
res=${RESOLUTION:-384x216} depth=${MAX_DEPTH:-7} spp=${SPP:-4}
command -v perf > /dev/null || { echo "perf not found (apt-get install linux-perf)" >&2; exit 1; }
if [[ -z ${BIN:-} ]]; then
  (cd "$root" && cargo build --release --quiet)
  BIN=$root/target/release/charted
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# Builds from before `--roulette` existed never played roulette.
roulette=()
"$BIN" render --help 2> /dev/null | grep -q -- '--roulette <' && roulette=(--roulette 0)

printf '%-8s %9s %9s %9s %12s\n' algo "traverse" "prim+hit" "all rays" "bound"
for algo in $algos; do
  n=$spp extra=()
  [[ $algo == pt ]] && n=$((4 * spp))
  [[ $algo == pt || $algo == bdpt || $algo == pssmlt ]] && extra=("${roulette[@]}")
  perf record -q -F 999 -o "$out/perf.data" "$BIN" render "$scene" --algo "$algo" --spp "$n" \
    --resolution "$res" --max-depth "$depth" --threads 1 "${extra[@]}" -o "$out/img.exr" \
    > "$out/log" 2>&1 || { cat "$out/log" >&2; exit 1; }
  # Self time per symbol; the queries are `Bvh::closest_hit*` and `Bvh::occluded*` (their
  # traversal; obvhs's `ray_traverse*` in builds before issue 17 expanded it into them), the
  # closures inside them (primitive tests) and the hit's surface point.
  perf report -i "$out/perf.data" --no-children --sort symbol --stdio 2> /dev/null |
    awk -v algo="$algo" '
      /%/ && !/^#/ {
        share = $1; sub(/%/, "", share)
        if (($0 ~ /accel::Bvh::(closest_hit|occluded)[_a-z0-9]*($|[^:])/ && $0 !~ /closure/) ||
            $0 ~ /obvhs::cwbvh::CwBvh::ray_traverse/) t += share
        else if ($0 ~ /accel::Bvh::(closest_hit|occluded)_in::\{\{closure\}\}/ ||
                 $0 ~ /Triangle::point_shaded|Sphere::point|Sphere::intersect|Triangle::intersect/) p += share
      }
      END { r = t + p; printf "%-8s %8.1f%% %8.1f%% %8.1f%% %11.2f×\n", algo, t, p, r, (r > 0 ? 100 / r : 0) }'
done
echo "bound: the speed-up if everything but the ray queries took no time at all"

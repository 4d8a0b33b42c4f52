#!/bin/bash
# Equal-time comparison for density estimation as an independence sampler in charted MLT
# (README, "Density estimation as an independence sampler"): bdpt, cmlt, cmlt with density
# estimation (--density-estimation 0.3, eq. 29), memlt and mept, T each (default 30 s), on pool,
# cornell, caustic and door at 256×256 and on examples/scenes/glossy-caustic.pbrt (320×240),
# against long BDPT references. Run from the repository root after `cargo build --release`; do
# not compile while it runs (equal time).
# B: the binary to measure; T: time per render; OUT: where to write; SCENES: which scenes;
# SEED: the renders' seed.
set -e
B=${B:-target/release/charted}
T=${T:-30s}
OUT=${OUT:-out/de-compare}
SCENES=${SCENES:-pool cornell caustic door glossy-caustic}
SEED=${SEED:-1}
mkdir -p "$OUT" out/ref
scene() { case $1 in glossy-caustic) echo examples/scenes/glossy-caustic.pbrt ;; *) echo $1 ;; esac; }
res() { case $1 in glossy-caustic) echo 320x240 ;; *) echo 256x256 ;; esac; }
for s in $SCENES; do
  [ -f out/ref/$s.exr ] || $B reference $(scene $s) --time 8m --resolution $(res $s) -o out/ref/$s.exr > "$OUT/ref-$s.log" 2>&1
done
printf "%-15s %-8s %12s %12s  %s\n" scene method RMSE relMSE "merges (made/proposed, accepted)"
for s in $SCENES; do
  for v in bdpt cmlt cmlt-de memlt mept; do
    case $v in
      cmlt-de) args="--algo cmlt --density-estimation 0.3" ;;
      *) args="--algo $v" ;;
    esac
    $B render $(scene $s) $args --time $T --seed $SEED --resolution $(res $s) -o "$OUT/$s-$v.exr" > "$OUT/$s-$v.log" 2>&1
    d=$($B diff "$OUT/$s-$v.exr" out/ref/$s.exr | grep RMSE)
    rmse=$(echo "$d" | awk '{print $2}')
    rel=$(echo "$d" | awk '{print $6}')
    m=$(grep "density estimation: merge" "$OUT/$s-$v.log" | awk '{print $4-$9 "/" $4 ", " $5}' || true)
    printf "%-15s %-8s %12s %12s  %s\n" $s $v "$rmse" "$rel" "$m"
  done
done

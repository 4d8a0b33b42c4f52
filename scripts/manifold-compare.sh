#!/bin/bash
# Equal-time comparison of bdpt, pssmlt, mlt, erpt, cmlt, memlt and mept (60 s each) on the scenes
# with specular chains, against long BDPT references (README, "Manifold exploration"). Run from the
# repository root after `cargo build --release`; do not compile while it runs (equal time).
# B: the binary to measure; V: the veach-bidir scene file; OUT: where to write.
set -e
B=${B:-target/release/charted}
V=${V:-../shared/scenes/veach-bidir/scene.pbrt}
OUT=${OUT:-out/manifold-compare}
mkdir -p "$OUT" out/ref
for s in cornell caustic ring pool; do
  [ -f out/ref/$s.exr ] || $B reference $s --time 8m --resolution 256x256 -o out/ref/$s.exr > "$OUT/ref-$s.log" 2>&1
done
[ -f out/ref/veach-bidir.exr ] || $B reference "$V" --time 10m --resolution 256x144 -o out/ref/veach-bidir.exr > "$OUT/ref-veach.log" 2>&1
A=bdpt,pssmlt,mlt,erpt,cmlt,memlt,mept
for s in cornell caustic ring pool; do
  $B compare $s --algos $A --time 60s --resolution 256x256 --reference out/ref/$s.exr -o "$OUT/$s" > "$OUT/$s.log" 2>&1
done
$B compare "$V" --algos $A --time 60s --resolution 256x144 --reference out/ref/veach-bidir.exr -o "$OUT/veach-bidir" > "$OUT/veach-bidir.log" 2>&1

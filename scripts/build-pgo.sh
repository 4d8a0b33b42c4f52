#!/usr/bin/env bash
# An opt-in profile-guided build of `charted` (rustc's -Cprofile-generate/-Cprofile-use) with
# whole-program optimisation (the `fast` profile: fat LTO, one codegen unit): an instrumented build
# renders a training set (every method on the built-in scenes, small images), and the program is
# compiled again with those branch and call counts. The default build (`cargo build --release`)
# is unchanged; this one runs on the same CPUs and renders the same images bit for bit. Prints
# the path of the optimized binary. Needs rustup's `llvm-tools` component, which it adds.
#
#   scripts/build-pgo.sh            # builds in target/pgo (about 8 minutes on two cores)
#   PGO_DIR=/tmp/pgo scripts/build-pgo.sh
#   TARGET_CPU=x86-64-v3 scripts/build-pgo.sh   # also for CPUs with AVX2 and FMA only (Haswell,
#                                               # Zen and later); not for older CPUs
#
# Measured side by side against the default build in docs/performance.md (*A profile-guided build*).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dir=${PGO_DIR:-"$root/target/pgo"}
cd "$root"
rustup component add llvm-tools >&2
host=$(rustc -vV | sed -n 's/^host: //p')
profdata="$(rustc --print sysroot)/lib/rustlib/$host/bin/llvm-profdata"
[[ -x $profdata ]] || { echo "build-pgo: $profdata not found (rustup component llvm-tools)" >&2; exit 1; }
cpu=()
[[ -n ${TARGET_CPU:-} ]] && cpu=("-Ctarget-cpu=$TARGET_CPU")
rm -rf "$dir/profiles" "$dir/merged.profdata"
mkdir -p "$dir/profiles"
RUSTFLAGS="-Cprofile-generate=$dir/profiles ${cpu[*]:-}" \
  cargo build --profile fast --quiet --bin charted --target-dir "$dir/instrumented" >&2
trained="$dir/instrumented/fast/charted"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# The training set: each method on each built-in scene, once with two threads. Small images and
# short renders: what matters is which branches and calls are hot, not how long they run.
for scene in cornell caustic door ring pool; do
  for algo in pt bdpt pssmlt mmlt mlt cmlt memlt; do
    "$trained" render "$scene" --algo "$algo" --spp 2 --resolution 160x90 --max-depth 7 \
      --bootstrap 20000 -o "$out/img.exr" > /dev/null 2>&1 ||
      { echo "build-pgo: training render $scene $algo failed" >&2; exit 1; }
  done
done
"$profdata" merge -o "$dir/merged.profdata" "$dir/profiles"
RUSTFLAGS="-Cprofile-use=$dir/merged.profdata -Cllvm-args=-pgo-warn-missing-function=false ${cpu[*]:-}" \
  cargo build --profile fast --quiet --bin charted --target-dir "$dir/optimized" >&2
echo "$dir/optimized/fast/charted"

# Shared by scripts/speed-compare.sh and scripts/thread-scaling.sh (sourced, not run).

# The median of the numbers on standard input, one per line.
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

# The least of the numbers on standard input (on a shared machine other work only adds time, so
# the fastest of several runs is the closest to the program's own time).
minimum() { sort -g | head -n 1; }

# SUM plus the natural logarithm of VALUE (for geometric means: add_log SUM VALUE).
add_log() { awk -v s="$1" -v r="$2" 'BEGIN { print s + log(r) }'; }

# exp(SUM / N): the geometric mean of N values whose logarithms sum to SUM (geomean SUM N).
geomean() { awk -v s="$1" -v n="$2" 'BEGIN { printf "%.3f", exp(s / n) }'; }

# The name a scene is reported by: veach-bidir/scene.pbrt by its folder, other files by their
# stem, built-ins as given.
scene_name() {
  local name=$1
  if [[ -f $1 ]]; then
    name=$(basename "$1" .pbrt)
    [[ $name == scene ]] && name=$(basename "$(dirname "$1")")
  fi
  echo "$name"
}

# Shared by scripts/speed-compare.sh and scripts/thread-scaling.sh (sourced, not run).

# The median of the numbers on standard input, one per line.
median() { sort -g | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }

# The least of the numbers on standard input (on a shared machine other work only adds time, so
# the fastest of several runs is the closest to the program's own time).
minimum() { sort -g | head -n 1; }

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

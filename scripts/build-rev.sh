#!/usr/bin/env bash
# Build an older revision of this repository in a git worktree beside it (../charted-REV, or
# OLD_DIR) and print the path of its release binary. Used by the scripts that compare builds.
#
#   scripts/build-rev.sh REV
set -euo pipefail
rev=$1
root=$(cd "$(dirname "$0")/.." && pwd)
old=${OLD_DIR:-"$root/../charted-$rev"}
cd "$root"
if [[ ! -d $old ]]; then git worktree add --detach "$old" "$rev" >&2; fi
(cd "$old" && cargo build --release --quiet >&2)
echo "$old/target/release/charted"

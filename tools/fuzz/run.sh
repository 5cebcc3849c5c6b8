#!/usr/bin/env bash
# Seeds the corpus of a fuzz target from the repository's scenes and the hand-written seeds,
# then fuzzes it for a while in one process (one core).
#
# usage: tools/fuzz/run.sh TARGET [SECONDS] [extra libFuzzer flags...]
#   TARGET:  scene_toml | obj_mtl | set_override
#   SECONDS: fuzzing time (default 60)
# e.g.     tools/fuzz/run.sh obj_mtl 1200
#
# Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`). Builds with
# optimizations plus debug assertions and overflow checks, without a sanitizer (the loader
# is safe Rust; assertions and panics are what the targets look for). The corpus lives in
# tools/fuzz/corpus/TARGET, crashes in tools/fuzz/artifacts/TARGET (both git-ignored).
# The targets type-check on stable too: cargo check --manifest-path tools/fuzz/Cargo.toml --bins
# Minimize a crash with:
#   cargo +nightly fuzz tmin --fuzz-dir tools/fuzz -O -a -s none TARGET tools/fuzz/artifacts/TARGET/crash-...
set -euo pipefail
target=${1:?usage: tools/fuzz/run.sh TARGET [SECONDS] [libFuzzer flags...]}
secs=${2:-60}
shift $(( $# < 2 ? $# : 2 ))
fuzz=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$fuzz/../.." && pwd)
corpus=$fuzz/corpus/$target
mkdir -p "$corpus"

sep=$'\n%%MTL%%\n'
case $target in
  scene_toml)
    cp "$repo"/scenes/*.toml "$corpus"/
    ;;
  obj_mtl)
    { cat "$repo/scenes/cornell-box/cornell-box.obj"; printf '%s' "$sep"; cat "$repo/scenes/cornell-box/cornell-box.mtl"; } \
      > "$corpus/seed-cornell-box"
    cp "$repo/scenes/cube/cube.obj" "$corpus/seed-cube"
    ;;
  set_override) ;;
  *) echo "unknown target $target (scene_toml, obj_mtl, set_override)" >&2; exit 2 ;;
esac
cp "$fuzz/seeds/$target"/* "$corpus"/
# Earlier findings, kept as regression inputs, seed the corpus too.
if [ -d "$repo/tests/data/fuzz/$target" ]; then
  cp "$repo/tests/data/fuzz/$target"/* "$corpus"/
fi

cd "$repo"
exec cargo +nightly fuzz run --fuzz-dir tools/fuzz -O -a -s none "$target" "$corpus" -- \
  -dict="$fuzz/keywords.dict" -max_total_time="$secs" -print_final_stats=1 "$@"

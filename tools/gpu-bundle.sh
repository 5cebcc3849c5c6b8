#!/usr/bin/env bash
# Packs what tools/gpu-report.sh needs on a GPU machine that has no Rust toolchain and no
# Vulkan loader or validation layer (only the NVIDIA driver and its ICD):
#
#   tools/gpu-bundle.sh [--no-tests] [--bench-at COMMIT]... [DIR]   (default DIR: .gpu, which git ignores)
#
# --no-tests leaves the test executables out (a bundle of a few MiB where the tests' 12 would
# take the working tree over what the device tool carries); tools/gpu-report.sh then records its
# tests group as skipped. --bench-at COMMIT (repeatable) adds `bench` built at COMMIT, as
# bin/bench-COMMIT, to compare the cost of one scene at several commits on one GPU in one call
# (a git worktree per commit, built in target/bench-at; e.g.
# docs/bench/nvidia-h200/run-6be6713/ds3.sh).
#
# DIR then holds bundle.tar.xz with: the release binaries (dvsgi, bench, soak), every test
# executable (they find the repository through the path they were built in, recorded in
# manifest-dir), the shared scenes the report and the tests render (Cornell box, Dabrovic's Sponza,
# bump-test; not Crytek's Sponza, 70 MiB), and
# the Debian packages of the Vulkan loader, the Khronos validation layer and libglvnd. On the GPU
# machine, from the repository root:
#
#   tools/gpu-report.sh --bundle DIR OUT_DIR
#
# Needs: cargo, python3, apt-get (Debian/Ubuntu, amd64 packages), xz, ../shared/scenes.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
with_tests=1
bench_at=()
while [ $# -gt 0 ]; do
  case "$1" in
    --no-tests) with_tests=0 ;;
    --bench-at) bench_at+=("${2:?--bench-at needs a commit}"); shift ;;
    -*) echo "usage: tools/gpu-bundle.sh [--no-tests] [--bench-at COMMIT]... [DIR]" >&2; exit 2 ;;
    *) break ;;
  esac
  shift
done
dir="${1:-$root/.gpu}"
mkdir -p "$dir"
dir="$(cd "$dir" && pwd)"
stage="$(mktemp -d)"
trap 'rm -rf "$stage"' EXIT
cd "$root"
mkdir -p "$stage"/{bin,tests,debs,shared/scenes}

echo "gpu-bundle: building release binaries$([ $with_tests = 1 ] && echo " and test executables")"
cargo build --release --locked --bins
: >"$stage/tests.tsv"
[ $with_tests = 1 ] && cargo test --release --locked --no-run --message-format=json 2>/dev/null |
  python3 -c '
import json, sys
for line in sys.stdin:
    try:
        m = json.loads(line)
    except ValueError:
        continue
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["profile"].get("test"):
        kind = m["target"]["kind"][0]
        name = "unit" if kind == "lib" else m["target"]["name"]
        print(name + "\t" + m["executable"])
' >"$stage/tests.tsv"
while IFS=$'\t' read -r name exe; do
  case "$name" in
    split_queues|dvsgi_split_queues|shaderc_link) continue ;; # lavapipe-only / build helpers
  esac
  cp "$exe" "$stage/tests/$name"
done <"$stage/tests.tsv"
for b in dvsgi bench soak; do cp "target/release/$b" "$stage/bin/"; done
for c in "${bench_at[@]}"; do
  short="$(git rev-parse --short "$c")"
  echo "gpu-bundle: bench at $short"
  tree="$(mktemp -d)"
  git worktree add -f --detach "$tree" "$short" >/dev/null
  (cd "$tree" && CARGO_TARGET_DIR="$root/target/bench-at" cargo build --release --locked --bin bench)
  cp "$root/target/bench-at/release/bench" "$stage/bin/bench-$short"
  git worktree remove --force "$tree"
done
strip "$stage"/bin/* "$stage"/tests/* 2>/dev/null || true
echo "$root" >"$stage/manifest-dir"
git rev-parse HEAD >"$stage/commit" 2>/dev/null || echo unknown >"$stage/commit"
git status --porcelain --untracked-files=no | grep -q . && echo "(with uncommitted changes)" >>"$stage/commit" || true

echo "gpu-bundle: shared scenes"
scenes="$root/../shared/scenes"
cp "$scenes/README.md" "$stage/shared/scenes/" 2>/dev/null || true
cp -r "$scenes/cornell-box" "$scenes/sponza-dabrovic" "$scenes/bump-test" "$stage/shared/scenes/"

echo "gpu-bundle: Vulkan loader and validation layer packages (amd64)"
lists="$(mktemp -d)"
o=(-q -oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists="$lists" -oAPT::Sandbox::User=root)
mkdir -p "$lists/partial"
apt-get "${o[@]}" update -qq
# The NVIDIA Vulkan driver (libGLX_nvidia) needs libglvnd's dispatch libraries, which a
# CUDA-only image may lack: without them the loader finds no driver.
(cd "$stage/debs" && apt-get "${o[@]}" download libvulkan1 vulkan-validationlayers libglvnd0 libgl1 libglx0 \
  libegl1 libgles2 libopengl0)
rm -rf "$lists"

# One xz stream with a dictionary larger than the test executables together (about 140 MiB):
# they share most of their bytes (the library, the shaders), which xz's default 8 MiB window
# cannot see across. 30 MB with `tar -cJ`, 18 MB so (two minutes on two cores); the device
# tool carries at most 64 MiB of working tree and bundle together.
tar -C "$stage" -cf - . | xz -T1 --lzma2=preset=9,dict=256MiB >"$dir/bundle.tar.xz"
ls -la "$dir/bundle.tar.xz"
tracked=$(git ls-files -z | du -cb --files0-from=- 2>/dev/null | tail -1 | cut -f1)
total=$(((tracked + $(stat -c %s "$dir/bundle.tar.xz")) / 1048576))
echo "gpu-bundle: the repository's tracked files and the bundle come to $total MiB (the device tool carries 64)"
[ "$total" -lt 64 ] || echo "gpu-bundle: warning: over 64 MiB; leave the test executables out (tests/) or carry less" >&2
echo "gpu-bundle: $(wc -l <"$stage/tests.tsv") test executables; carry $dir and run tools/gpu-report.sh --bundle $dir OUT_DIR"

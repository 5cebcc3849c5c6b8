#!/usr/bin/env bash
# Runs CMD ARGS... with the queue-splitting layer (tools/split-queues) active: a device with one
# queue (lavapipe) then shows a graphics family and a separate compute-only family, both backed
# by its one queue, and the Khronos validation layer above checks the application's
# queue-family ownership transfers and cross-queue synchronization as on such a GPU.
#
#   tools/with-split-queues.sh target/debug/dvsgi info
#   tools/with-split-queues.sh cargo test --test schedule
#
# Layer order matters: the loader puts layers named in VK_INSTANCE_LAYERS above those the
# application enables, so both are named here, validation first (nearer the application). The
# validation layer is therefore always loaded under this script; what it reports reaches the
# application only if the application asks for it (dvsgi: --validation or DVSGI_VALIDATION=1).
# On a device that already has several queue families or queues the layer changes nothing.
#
# Environment: DVSGI_SPLIT_QUEUES_TRACE=FILE appends one line per queue submit (the waits and
# signals actually handed to vkQueueSubmit2) to FILE. The layer is (re)built with cargo when
# its library is missing or older than its sources.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
if [ $# -eq 0 ]; then
  echo "usage: tools/with-split-queues.sh CMD [ARGS...]" >&2
  exit 2
fi
target="${CARGO_TARGET_DIR:-$root/target}"
lib="$target/debug/libdvsgi_split_queues.so"
stale=1
if [ -f "$lib" ]; then
  stale=0
  for f in "$root"/tools/split-queues/src/*.rs "$root"/tools/split-queues/Cargo.toml; do
    if [ "$f" -nt "$lib" ]; then stale=1; fi
  done
fi
if [ "$stale" = 1 ]; then
  (cd "$root" && cargo build --quiet --locked -p dvsgi-split-queues) >&2
fi
dir="$target/split-queues-layer"
mkdir -p "$dir"
manifest="$dir/VK_LAYER_DVSGI_split_queues.json"
tmp="$manifest.$$"
cat >"$tmp" <<JSON
{
  "file_format_version": "1.1.2",
  "layer": {
    "name": "VK_LAYER_DVSGI_split_queues",
    "type": "GLOBAL",
    "library_path": "$lib",
    "api_version": "1.3.0",
    "implementation_version": "1",
    "description": "dvsgi: one queue shown as a graphics family and a compute-only family"
  }
}
JSON
mv -f "$tmp" "$manifest"
# VK_LAYER_PATH (older loaders lack VK_ADD_LAYER_PATH) replaces the search path for explicit
# layers, so the standard directories, where the validation layer lives, are named too.
std="${XDG_DATA_HOME:-${HOME:-/root}/.local/share}/vulkan/explicit_layer.d:/usr/local/share/vulkan/explicit_layer.d"
std="$std:/usr/share/vulkan/explicit_layer.d:/etc/vulkan/explicit_layer.d"
case ":${VK_LAYER_PATH:-}:" in
  *":$dir:"*) ;;
  *) export VK_LAYER_PATH="$dir:${VK_LAYER_PATH:-$std}" ;;
esac
case ":${VK_INSTANCE_LAYERS:-}:" in
  *:VK_LAYER_DVSGI_split_queues:*) ;; # already under this script
  *) export VK_INSTANCE_LAYERS="VK_LAYER_KHRONOS_validation:VK_LAYER_DVSGI_split_queues${VK_INSTANCE_LAYERS:+:$VK_INSTANCE_LAYERS}" ;;
esac
# Tests check that they really run on the split device (tests/common).
# The loader announces VK_INSTANCE_LAYERS as a warning on stderr; keep its errors only.
export VK_LOADER_DEBUG="${VK_LOADER_DEBUG:-error}"
export DVSGI_SPLIT_QUEUES=1
exec "$@"

#!/usr/bin/env bash
# The test command: set-up (system packages) then every test, on the Vulkan device the loader
# finds (lavapipe on a machine without a GPU) with the Khronos validation layer on.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
cargo test --locked "$@"

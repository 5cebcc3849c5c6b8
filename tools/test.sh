#!/usr/bin/env bash
# The test command: set-up (system packages) then every test, on the Vulkan device the loader
# finds (lavapipe on a machine without a GPU) with the Khronos validation layer on; then the
# async path again on a split device (tools/with-split-queues.sh: a separate compute-only
# queue family, as on an NVIDIA GPU) with the two queues run in the two adversarial orders, so
# a missing semaphore wait, release or acquire fails a test. Extra arguments go to cargo
# (e.g. --release).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
# The queue-splitting layer first: tests/split_queues.rs runs dvsgi under it.
cargo build --locked -p dvsgi-split-queues
cargo test --locked "$@"
cargo test --locked -p dvsgi-split-queues "$@"
for order in compute-first graphics-first; do
  echo "test.sh: the schedule tests (cone tracing, RSM, LPV, the mix), synchronization validation, bench and the viewer on the split device ($order)"
  export DVSGI_SPLIT_QUEUES_ORDER="$order"
  tools/with-split-queues.sh cargo test --locked "$@" --test schedule
  tools/with-split-queues.sh cargo test --locked "$@" --test rsm -- \
    every_mode_renders_the_same_rsm_and_lpv_image the_mix_puts_the_gather_on_compute_and_the_volume_on_graphics
  tools/with-split-queues.sh cargo test --locked "$@" --test cli --test bench -- \
    every_schedule_is_clean_under_queue_submit_synchronization_validation \
    info_reports_device_and_queue_topology bench_smoke the_schedule_model_predicts
  tools/with-split-queues.sh cargo test --locked "$@" --test view -- \
    a_capture_is_what_render_makes_of_the_scene_file_it_writes
done

//! A short soak in every schedule mode (the long runs are in docs/ROBUSTNESS.md): the dynamic
//! stress scene (moving objects and a circling light) revoxelized, relit and bounced every
//! frame. gpu-allocator's figures do not move, resident memory stays flat, the image at a fixed
//! scene time is the same whatever ran before it, and validation stays clean. Alone in its
//! test binary, so resident memory is this test's.

mod common;

use common::*;
use dvsgi::render::Mode;
use dvsgi::soak::{soak_mode, SoakOptions};

#[test]
fn memory_is_flat_and_the_image_stable_over_many_dynamic_frames_in_every_mode() {
    let ctx = context();
    let scene = load(
        &repo().join("scenes/dynamic-stress.toml"),
        &[("render.width", "16"), ("render.height", "16"), ("gi.voxel_resolution", "16"), ("gi.update_interval", "1")],
    );
    let o = SoakOptions { frames: 90, sample_every: 30, dt: 1.0 / 30.0, frames_in_flight: 2 };
    for mode in [Mode::Sync, Mode::Async, Mode::AsyncLagged] {
        let m = soak_mode(&ctx, &scene, mode, &o, |s| eprintln!("{}: {s:?}", mode.name())).unwrap();
        assert_eq!(m.samples.len(), 4);
        let first = &m.samples[0];
        for s in &m.samples {
            assert_eq!(
                (s.gpu_allocated_bytes, s.gpu_block_bytes, s.gpu_allocations, s.gpu_blocks),
                (first.gpu_allocated_bytes, first.gpu_block_bytes, first.gpu_allocations, first.gpu_blocks),
                "{}: GPU memory moved at frame {}",
                mode.name(),
                s.frame
            );
            assert!(
                s.drift <= 1e-4,
                "{}: the fixed-time image drifted by {} at frame {}",
                mode.name(),
                s.drift,
                s.frame
            );
            assert_eq!(s.validation_messages, 0);
        }
        let rss = m.growth(|s| s.rss_bytes) as f64 / 1048576.0;
        assert!(rss < 4.0, "{}: resident memory grew {rss:.2} MiB in {} frames", mode.name(), o.frames);
    }
    assert_no_validation_messages(&ctx);
}

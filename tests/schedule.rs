//! The schedule modes on the real device (lavapipe: one queue, so the async modes submit both
//! streams to it), validation and synchronization validation on: the same image in every
//! mode, rising timeline values, no host wait inside a frame, the serial profile.

mod common;

use common::*;
use dvsgi::render::graph::QueueKind;
use dvsgi::render::{Mode, RenderOptions, Renderer};
use dvsgi::scene::Scene;
use std::collections::HashMap;

fn scene(file: &str, overrides: &[(&str, &str)]) -> Scene {
    let mut all = vec![("render.width", "48"), ("render.height", "48"), ("gi.voxel_resolution", "16")];
    all.extend_from_slice(overrides);
    load(&repo().join("scenes").join(file), &all)
}

/// Every cross-queue path at once: glossy (specular cone), cone shadows, half-resolution
/// tracing with the upsample, two bounces. Without bounce feedback, so that every frame of a
/// static scene is the same (with it, each update adds bounces until the light converges).
fn everything() -> Scene {
    scene(
        "cornell-glossy.toml",
        &[
            ("gi.shadows", "\"cone\""),
            ("gi.downsample", "2"),
            ("gi.bounces", "2"),
            ("gi.diffuse_cones", "4"),
            ("gi.bounce_feedback", "false"),
        ],
    )
}

#[test]
fn every_mode_renders_the_same_image_of_a_static_scene() {
    let ctx = context();
    let s = everything();
    let t = s.settings.time;
    // One renderer switching modes: the voxelization (whose atomic averages depend on the
    // order fragments arrive) is shared, so any difference would come from the schedule.
    let mut r = Renderer::with_options(&ctx, s, RenderOptions { mode: Mode::Sync, frames_in_flight: 2 }).unwrap();
    r.render(t, true).unwrap();
    r.render(t, true).unwrap();
    let sync = r.output().radiance;
    assert!(sync.iter().any(|v| *v > 0.0));
    for mode in [Mode::Async, Mode::AsyncLagged, Mode::Sync, Mode::AsyncPipelined, Mode::AsyncPipelined, Mode::Async] {
        r.set_mode(mode).unwrap();
        r.render(t, true).unwrap();
        let out = r.output().radiance;
        let differing = sync.iter().zip(&out).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{mode}: {differing} values differ from sync");
        if mode != Mode::Sync {
            let queues: Vec<_> = r.scheduler().submits().iter().map(|s| s.queue).collect();
            assert!(queues.contains(&QueueKind::Compute), "{mode}: compute work was submitted: {queues:?}");
        }
    }
    // async-lagged really traces before relighting.
    r.set_mode(Mode::AsyncLagged).unwrap();
    r.render(t, false).unwrap();
    let names = r.last_pass_names();
    let pos = |n: &str| names.iter().position(|p| p == n).unwrap_or_else(|| panic!("{n} in {names:?}"));
    assert!(pos("cone trace") < pos("voxel light"), "{names:?}");
    r.wait_idle().unwrap();
    drop(r);
    assert_no_validation_messages(&ctx);
}

#[test]
fn async_lagged_equals_sync_after_the_first_frame_of_a_static_scene() {
    let ctx = context();
    // Without bounce feedback every frame of a static scene is the same.
    let s = scene("cornell-box.toml", &[("gi.bounce_feedback", "false")]);
    let t = s.settings.time;
    let mut r =
        Renderer::with_options(&ctx, s, RenderOptions { mode: Mode::AsyncLagged, frames_in_flight: 2 }).unwrap();
    r.render(t, true).unwrap();
    // The first frame has no previous voxel radiance, so it is not lagged.
    assert!(
        r.last_pass_names().iter().position(|p| p == "voxel light")
            < r.last_pass_names().iter().position(|p| p == "cone trace")
    );
    r.render(t, true).unwrap();
    let lagged = r.output().radiance;
    r.set_mode(Mode::Sync).unwrap();
    r.render(t, true).unwrap();
    assert_eq!(r.output().radiance, lagged);
    drop(r);
    assert_no_validation_messages(&ctx);
}

#[test]
fn lag_shows_as_image_error_under_motion() {
    let ctx = context();
    // Objects and the light move; two renderers differ a little anyway (the voxelization's
    // atomic averages depend on fragment order), which async against sync measures.
    let s = load(
        &repo().join("scenes/dynamic-stress.toml"),
        &[("render.width", "48"), ("render.height", "48"), ("gi.voxel_resolution", "16")],
    );
    let render_at = |mode: Mode, frames: &[f32]| {
        let mut r = Renderer::with_options(&ctx, s.clone(), RenderOptions { mode, frames_in_flight: 2 }).unwrap();
        for &t in frames {
            r.render(t, true).unwrap();
        }
        r.output().radiance
    };
    let times = [0.0, 0.5];
    let sync = render_at(Mode::Sync, &times);
    let asynchronous = render_at(Mode::Async, &times);
    let lagged = render_at(Mode::AsyncLagged, &times);
    let floor = dvsgi::bench::relative_error(&sync, &asynchronous);
    let lag = dvsgi::bench::relative_error(&sync, &lagged);
    eprintln!("relative error vs sync: async {floor:.5}, async-lagged {lag:.5}");
    assert!(lag > 0.005, "the light moved 45 degrees between frames, lagged GI must differ: {lag}");
    assert!(lag > 3.0 * floor, "lag error {lag} against the two-renderer noise floor {floor}");
    assert_no_validation_messages(&ctx);
}

/// async-pipelined (issue 40): from the submits of bench's timed frames, no graphics submit
/// of frame N+1 waits for a compute value of frame N's cone trace or later, so the graphics
/// queue draws N+1 while the compute queue traces N: in a static scene relit every frame, and
/// in one whose objects move (revoxelized every frame, dense volumes: it waits for N's voxel
/// light, before the trace). The tail runs on compute, and there are two copies of the frame.
#[test]
fn pipelined_graphics_never_waits_for_the_previous_frames_cone_trace() {
    let ctx = context();
    for (file, dt) in [("cornell-box.toml", None), ("dynamic-test.toml", Some(0.05))] {
        let s = scene(file, &[("gi.voxel_layout", "\"dense\"")]);
        let m = dvsgi::bench::Measure {
            mode: Mode::AsyncPipelined,
            frames: 4,
            warmup: 1,
            frames_in_flight: 2,
            serial_profile: false,
            raster_profile: false,
            dynamic_dt: dt,
            redraw: true,
        };
        let frames = dvsgi::bench::record_submits(&ctx, &s, &m).unwrap();
        assert_eq!(frames.len(), 4);
        for (n, pair) in frames.windows(2).enumerate() {
            let on =
                |q: QueueKind, name: &str| pair[0].iter().find(|s| s.queue == q && s.passes.iter().any(|p| p == name));
            let trace = on(QueueKind::Compute, "cone trace").expect("the trace on compute").signal;
            assert!(on(QueueKind::Compute, "tonemap").is_some(), "{file}: the tail on compute: {:?}", pair[0]);
            assert!(on(QueueKind::Graphics, "gbuffer").is_some(), "{file}: {:?}", pair[0]);
            for g in pair[1].iter().filter(|s| s.queue == QueueKind::Graphics) {
                assert!(
                    g.wait.map_or(true, |w| w < trace),
                    "{file}: frame {} graphics {:?} waits for compute {:?}, frame {n}'s cone trace is {trace}: {:?}",
                    n + 1,
                    g.passes,
                    g.wait,
                    pair[0]
                );
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn timeline_values_rise_and_the_host_never_waits_inside_a_frame() {
    let ctx = context();
    for mode in Mode::ALL {
        let s = scene("dynamic-test.toml", &[]);
        let mut r = Renderer::with_options(&ctx, s, RenderOptions { mode, frames_in_flight: 2 }).unwrap();
        let mut last = HashMap::new();
        let frames = 5;
        for i in 0..frames {
            r.request_voxel_update();
            r.render(i as f32 * 0.1, false).unwrap();
            let submits = r.scheduler().submits();
            assert!(!submits.is_empty());
            let mut signalled = last.clone();
            for s in submits {
                // Strictly rising per queue, frame after frame.
                let prev = signalled.insert(s.queue, s.signal).unwrap_or(0);
                assert!(s.signal > prev, "{mode}: {:?} signal {} after {prev}", s.queue, s.signal);
                // Every wait names a value the other queue was already asked to signal.
                if let Some(w) = s.wait {
                    let other = signalled.get(&s.queue.other()).copied().unwrap_or(0);
                    assert!(w <= other, "{mode}: {:?} waits for {w}, only {other} submitted", s.queue);
                }
            }
            last = signalled;
            if mode == Mode::Sync {
                assert_eq!(submits.len(), 1, "sync is one submit");
            } else {
                assert!(submits.iter().any(|s| s.queue == QueueKind::Compute && s.wait.is_some()));
            }
        }
        let w = r.scheduler().waits;
        assert_eq!(w.in_frame, 0, "{mode}: {w:?}");
        assert_eq!(w.readback, 0, "{mode}: {w:?}");
        // Only reusing a slot may wait: at most once per frame beyond the slots in flight.
        assert!(w.slot_reuse <= frames - 2, "{mode}: {w:?}");
        r.wait_idle().unwrap();
        let timings = r.take_timings();
        assert_eq!(timings.len(), frames as usize, "{mode}: every frame's timestamps are read");
        let queues: Vec<_> = timings[0].passes.iter().map(|p| p.queue).collect();
        assert_eq!(queues.contains(&QueueKind::Compute), mode != Mode::Sync, "{mode}: {queues:?}");
        for f in &timings {
            for p in &f.passes {
                assert!(p.end_ms >= p.begin_ms && p.begin_ms.is_finite(), "{mode}: {p:?}");
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

#[test]
fn one_frame_in_flight_waits_for_every_previous_frame() {
    let ctx = context();
    let s = scene("cornell-box.toml", &[("gi.mode", "\"none\"")]);
    let mut r = Renderer::with_options(&ctx, s, RenderOptions { mode: Mode::Async, frames_in_flight: 1 }).unwrap();
    for _ in 0..3 {
        r.render(0.0, false).unwrap();
    }
    let w = r.scheduler().waits;
    assert_eq!(w.in_frame, 0);
    assert!(w.slot_reuse <= 2, "{w:?}");
    assert!(Renderer::with_options(
        &ctx,
        scene("cornell-box.toml", &[]),
        RenderOptions { mode: Mode::Sync, frames_in_flight: 0 }
    )
    .is_err());
    drop(r);
    assert_no_validation_messages(&ctx);
}

#[test]
fn serial_profile_host_times_every_pass() {
    let ctx = context();
    let s = scene("cornell-box.toml", &[]);
    let mut r = Renderer::with_options(&ctx, s, RenderOptions { mode: Mode::Async, frames_in_flight: 2 }).unwrap();
    r.set_serial_profile(true);
    r.render(0.0, false).unwrap();
    let names = r.last_pass_names().to_vec();
    let times = r.scheduler().serial_times().to_vec();
    assert_eq!(times.iter().map(|t| t.name.clone()).collect::<Vec<_>>(), names);
    assert!(times.iter().all(|t| t.host_ms > 0.0));
    let light = times.iter().find(|t| t.name == "voxel light").unwrap();
    assert_eq!(light.queue, QueueKind::Compute);
    assert_eq!(r.scheduler().waits.in_frame, names.len() as u64, "the profile waits after each pass");
    r.set_serial_profile(false);
    r.wait_idle().unwrap();
    drop(r);
    assert_no_validation_messages(&ctx);
}

//! Resource limits on the real device (lavapipe in CI, validation on): settings beyond the
//! device are refused before anything is allocated, with the limit named; a failed allocation
//! is a clear error and the device stays usable; a GPU wait that times out is an error, and
//! teardown after it does not hang.

mod common;

use common::*;
use dvsgi::gpu::{Buffer, GpuError};
use dvsgi::render::budget::{Estimate, Limits};
use dvsgi::render::{Mode, RenderOptions, Renderer};
use gpu_allocator::MemoryLocation;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn cornell(overrides: &[(&str, &str)]) -> dvsgi::scene::Scene {
    let mut all = vec![("render.width", "32"), ("render.height", "32"), ("render.shadow_map_size", "128")];
    all.extend_from_slice(overrides);
    load(&repo().join("scenes/cornell-box.toml"), &all)
}

/// The estimate is within 10% of what creating the renderer really allocates, for a scene
/// whose volumes dominate and for one with every optional volume and target.
#[test]
fn memory_estimate_matches_what_is_allocated() {
    let ctx = context();
    for (label, o) in [
        ("cornell 64^3, auto", vec![("gi.voxel_resolution", "64")]),
        ("cornell 64^3 bricks", vec![("gi.voxel_resolution", "64"), ("gi.voxel_layout", "\"bricks\"")]),
        (
            "cornell 256^3, bricks pooling the directional level 0",
            vec![("gi.voxel_resolution", "256"), ("gi.voxel_layout", "\"bricks\"")],
        ),
        ("cornell 64^3 dense", vec![("gi.voxel_resolution", "64"), ("gi.voxel_layout", "\"dense\"")]),
        ("glossy, 2 bounces, cone shadows, 1/2 res", vec![("gi.voxel_resolution", "64"), ("gi.bounces", "2")]),
        ("rsm, 6 faces of 256^2, 1/2 res", vec![("gi.mode", "\"rsm\""), ("gi.downsample", "2")]),
        ("lpv 16^3, 6 faces of 256^2", vec![("gi.mode", "\"lpv\"")]),
    ] {
        let mut scene = cornell(&o);
        if label.starts_with("glossy") {
            scene = load(
                &repo().join("scenes/cornell-glossy.toml"),
                &[
                    ("render.width", "64"),
                    ("render.height", "64"),
                    ("gi.voxel_resolution", "64"),
                    ("gi.bounces", "2"),
                    ("gi.shadows", "\"cone\""),
                    ("gi.downsample", "2"),
                ],
            );
        }
        // "auto" as the renderer resolves it on this device.
        scene.settings.gi.voxel_layout = dvsgi::render::budget::resolve_layout(&scene, &Limits::of(&ctx));
        let estimate = Estimate::on(&ctx, &scene);
        let est = estimate.total() as f64;
        let before = ctx.allocated_bytes();
        let r = Renderer::new(&ctx, scene.clone()).unwrap();
        let got = (ctx.allocated_bytes() - before) as f64;
        drop(r);
        eprintln!("{label}: estimated {:.2} MiB, allocated {:.2} MiB", est / 1048576.0, got / 1048576.0);
        assert!((est / got - 1.0).abs() < 0.10, "{label}: estimate {est} vs allocated {got}");
        // async-pipelined, three frames in flight: two more copies of the frame's own images.
        if !label.contains("256") {
            let options = RenderOptions { mode: Mode::AsyncPipelined, frames_in_flight: 3 };
            let r = Renderer::with_options(&ctx, scene, options).unwrap();
            let (copies, est) = (r.copies_bytes() as f64, estimate.with_copies(3).copies as f64);
            eprintln!(
                "{label}: two more copies estimated {:.2} MiB, made {:.2} MiB",
                est / 1048576.0,
                copies / 1048576.0
            );
            assert_eq!(r.copy_count(), 3);
            assert!((est / copies - 1.0).abs() < 0.10, "{label}: copies estimated {est} vs made {copies}");
        }
    }
    assert_no_validation_messages(&ctx);
}

/// The voxel volumes' estimate is exactly what the renderer allocates for them, byte for byte,
/// in both layouts and with every optional volume (emission, static flags, bounces and their
/// tail's records, pooled directional levels): the estimate lists the allocations without creating them, and this is
/// what keeps that list and `VoxelVolumes::new` from drifting apart.
#[test]
fn voxel_volume_estimate_is_exactly_what_is_allocated() {
    let ctx = context();
    let scenes = [
        ("scenes/cornell-box.toml", "64", "dense"),
        ("scenes/cornell-box.toml", "256", "bricks"),
        ("scenes/dynamic-test.toml", "64", "dense"),
        ("scenes/dynamic-test.toml", "256", "bricks"),
        ("scenes/cornell-original.toml", "64", "bricks"),
    ];
    // Every scene with its closed backs as well (one more byte a voxel), but the last.
    for (i, (file, res, layout)) in scenes.into_iter().enumerate() {
        let layout_value = format!("\"{layout}\"");
        let backs = if i + 1 < scenes.len() { "\"closed\"" } else { "\"lit\"" };
        let overrides = [
            ("render.width", "16"),
            ("render.height", "16"),
            ("gi.voxel_resolution", res),
            ("gi.voxel_layout", &layout_value),
            ("gi.plane_backs", backs),
        ];
        let scene = load(&repo().join(file), &overrides);
        let estimate = Estimate::on(&ctx, &scene).volumes;
        let r = Renderer::new(&ctx, scene).unwrap();
        let v = r.voxels().expect("voxels");
        let images: u64 = v.all().into_iter().chain(&v.flags_placeholder).map(|i| i.bytes).sum();
        let tail = v.bounce_tail.as_ref().map_or(0, |t| t.buffer.size);
        let buffers = v.list.bytes() + v.scan.size + v.bricks.as_ref().map_or(0, |b| b.lists.size) + tail;
        assert_eq!(estimate, images + buffers, "{file} at {res}^3, {layout}");
    }
    assert_no_validation_messages(&ctx);
}

/// A voxel grid whose volumes exceed the device's memory heap is refused before anything is
/// allocated, naming the heap, the device and a resolution that fits (lavapipe's heap is 2 GiB;
/// 512^3 with one bounce needs 3.9 GiB).
#[test]
fn voxel_grid_beyond_the_device_is_refused_up_front() {
    let ctx = context();
    let scene = cornell(&[("gi.voxel_resolution", "512")]);
    let need = Estimate::of(&scene).total();
    if need <= ctx.info.device_local_heap {
        eprintln!("{}: a {need} B frame fits the heap; nothing to refuse here", ctx.info.name);
        return;
    }
    let before = ctx.allocated_bytes();
    let start = Instant::now();
    let err = Renderer::new(&ctx, scene).err().expect("refused");
    let msg = err.to_string();
    assert!(matches!(err, GpuError::Limit(_)), "{msg}");
    assert!(msg.contains("largest device-local memory heap") && msg.contains(&ctx.info.name), "{msg}");
    assert!(msg.contains("cornell-box.toml") && msg.contains("fits"), "{msg}");
    assert_eq!(ctx.allocated_bytes(), before, "something was allocated before the refusal");
    assert!(start.elapsed() < Duration::from_secs(5), "refusal took {:?}", start.elapsed());
    assert_no_validation_messages(&ctx);
}

/// A buffer larger than the device allows is an error naming it and the limit; the device
/// keeps working afterwards.
#[test]
fn an_impossible_allocation_is_a_clear_error_and_the_device_stays_usable() {
    let ctx = context();
    let size = ctx.info.device_local_heap.max(ctx.info.max_allocation).saturating_mul(4).max(1 << 40);
    let err =
        Buffer::new(&ctx, "huge test buffer", size, ash::vk::BufferUsageFlags::STORAGE_BUFFER, MemoryLocation::GpuOnly)
            .err()
            .expect("a buffer beyond the device's memory");
    let msg = err.to_string();
    assert!(msg.contains("huge test buffer"), "{msg}");
    assert!(msg.contains("MiB"), "{msg}");
    assert!(!ctx.has_failed());
    let (out, _) = render(&ctx, cornell(&[("gi.voxel_resolution", "16")]));
    assert!(out.radiance.iter().all(|v| v.is_finite()));
}

/// With a timeout shorter than any frame, the wait for the frame is a `Timeout` error, the
/// context is marked failed, and dropping the renderer and the context returns at once
/// (nothing waits for the GPU again).
#[test]
fn a_gpu_wait_that_times_out_is_an_error_not_a_hang() {
    let ctx = context();
    let mut r = Renderer::new(&ctx, cornell(&[("gi.voxel_resolution", "64"), ("gi.bounces", "2")])).unwrap();
    ctx.set_gpu_timeout(Duration::from_nanos(1));
    let start = Instant::now();
    let err = r.render(0.0, true).expect_err("a 1 ns timeout expires");
    assert!(matches!(err, GpuError::Timeout { .. }), "{err}");
    assert!(err.to_string().contains("DVSGI_GPU_TIMEOUT"), "{err}");
    assert!(ctx.has_failed());
    drop(r);
    drop(ctx);
    assert!(start.elapsed() < Duration::from_secs(10), "teardown waited: {:?}", start.elapsed());
}

/// The same from the command line: `DVSGI_GPU_TIMEOUT` is honoured, the process exits with
/// status 1 and the message, writes nothing, and does not hang; a malformed value is refused.
#[test]
fn gpu_timeout_from_the_environment() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.png");
    let run = |timeout: &str| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_dvsgi"))
            .args(["render", "scenes/cornell-box.toml", "--out", out.to_str().unwrap()])
            .args(["--width", "32", "--height", "32", "--set", "gi.voxel_resolution=64"])
            .current_dir(repo())
            .env("DVSGI_VALIDATION", "1")
            .env("DVSGI_GPU_TIMEOUT", timeout)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while child.try_wait().unwrap().is_none() {
            if start.elapsed() > Duration::from_secs(120) {
                child.kill().unwrap();
                panic!("DVSGI_GPU_TIMEOUT={timeout}: hung");
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let o = child.wait_with_output().unwrap();
        (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let (code, err) = run("1e-9");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("timed out after") && !err.contains("panicked"), "{err}");
    assert!(!out.exists());
    let (code, err) = run("soon");
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("DVSGI_GPU_TIMEOUT=\"soon\""), "{err}");
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "files left behind");
}

//! The reference path tracer against analytic answers and against the rasterizer, on
//! lavapipe with validation on.

mod common;

use common::{assert_no_validation_messages, context, load, repo};
use dvsgi::reference::{PathTracer, ReferenceImage, ReferenceOptions, SpecularPaths};
use dvsgi::render::Renderer;
use dvsgi::scene::Scene;
use std::path::PathBuf;

/// A closed unit cube seen from inside: every face emits `le` and reflects `albedo`.
/// The radiance everywhere is the geometric series le / (1 - albedo), per channel.
fn furnace(dir: &std::path::Path, albedo: [f32; 3], le: [f32; 3]) -> PathBuf {
    let cube = repo().join("scenes/cube/cube.obj");
    let text = format!(
        r#"
[camera]
position = [0.1, -0.05, 0.2]
target = [-0.3, 0.1, -0.4]
fov_y = 100
near = 0.001

[render]
width = 24
height = 24

[gi]
mode = "none"

[[materials]]
name = "furnace"
albedo = {albedo:?}
emission = {le:?}

[[objects]]
obj = {cube:?}
material = "furnace"
"#
    );
    let path = dir.join("furnace.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn trace(scene: &Scene, spp: u32, seed: u32, max_bounces: Option<u32>, jitter: bool) -> ReferenceImage {
    trace_batched(scene, spp, seed, max_bounces, jitter, 200.0)
}

fn trace_batched(
    scene: &Scene,
    spp: u32,
    seed: u32,
    max_bounces: Option<u32>,
    jitter: bool,
    batch_ms: f64,
) -> ReferenceImage {
    let options = ReferenceOptions { spp, max_bounces, seed, batch_ms, jitter, ..Default::default() };
    let image = common::trace_reference(scene, options);
    assert_eq!(image.spp, spp);
    image
}

#[test]
fn furnace_converges_to_the_geometric_series() {
    let dir = tempfile::tempdir().unwrap();
    let albedo = [0.2, 0.5, 0.8];
    let scene = load(&furnace(dir.path(), albedo, [1.0, 1.0, 1.0]), &[]);
    let image = trace(&scene, 256, 1, None, true);
    let n = (image.width * image.height) as usize;
    for (c, a) in albedo.iter().enumerate() {
        let expect = 1.0 / (1.0 - *a as f64);
        let mean = (0..n).map(|i| image.mean[i * 3 + c] as f64).sum::<f64>() / n as f64;
        let sigma_of_mean = ((0..n).map(|i| image.variance[i * 3 + c] as f64).sum::<f64>()).sqrt() / n as f64;
        println!("channel {c}: image mean {mean:.5}, analytic {expect:.5}, standard error {sigma_of_mean:.5}");
        assert!(sigma_of_mean > 0.0 && sigma_of_mean < 0.005 * expect, "too noisy to judge: {sigma_of_mean}");
        assert!(
            (mean - expect).abs() < 4.0 * sigma_of_mean + 1e-4 * expect,
            "channel {c}: {mean} vs {expect} (standard error {sigma_of_mean})"
        );
        // Every pixel agrees within its own error bars (5 sigma: 576 pixels per channel).
        for i in 0..n {
            let (m, s) = (image.mean[i * 3 + c] as f64, (image.variance[i * 3 + c] as f64).sqrt());
            assert!((m - expect).abs() < 5.0 * s + 1e-3, "pixel {i} channel {c}: {m} vs {expect} (sigma {s})");
        }
    }
    // The batching does not change the estimate: one sample per batch against everything
    // after the first in one batch (llvmpipe once cut long invocations short).
    let one = trace_batched(&scene, 64, 3, None, true, 0.0);
    let all = trace_batched(&scene, 64, 3, None, true, 1e9);
    let mean = |i: &ReferenceImage| i.mean.iter().map(|&v| v as f64).sum::<f64>() / i.mean.len() as f64;
    assert!((mean(&one) - mean(&all)).abs() < 1e-5 * mean(&one), "{} vs {}", mean(&one), mean(&all));
    // Direct light only: the walls' own emission, exactly.
    let direct = trace(&scene, 4, 2, Some(0), true);
    assert!(direct.mean.iter().all(|&v| (v - 1.0).abs() < 1e-6), "direct-only furnace is not the emission");
}

#[test]
fn error_falls_like_one_over_root_spp() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&furnace(dir.path(), [0.6, 0.6, 0.6], [1.0, 1.0, 1.0]), &[]);
    let expect = 1.0 / (1.0 - 0.6);
    let mut points = Vec::new();
    for (k, spp) in [4u32, 16, 64].into_iter().enumerate() {
        let image = trace(&scene, spp, 100 + k as u32, None, true);
        let mse = image.mean.iter().map(|&v| (v as f64 - expect).powi(2)).sum::<f64>() / image.mean.len() as f64;
        let predicted = image.variance.iter().map(|&v| v as f64).sum::<f64>() / image.variance.len() as f64;
        println!("{spp:>3} spp: RMSE {:.5}, predicted by the variance image {:.5}", mse.sqrt(), predicted.sqrt());
        // The variance image predicts the real error.
        assert!((0.7..1.4).contains(&(mse / predicted)), "variance estimate off: mse {mse}, predicted {predicted}");
        points.push(((spp as f64).ln(), mse.sqrt().ln()));
    }
    let slope = common::slope(&points);
    println!("slope {slope:.3}");
    assert!((slope + 0.5).abs() < 0.08, "log RMSE / log spp slope {slope}, expected -0.5");
}

#[test]
fn direct_only_matches_the_rasterizer() {
    // The Cornell box with indirect light off in both: path-traced direct light (exact
    // visibility, paths through pixel centres) against the rasterizer's (shadow maps, PCF).
    let path = repo().join("scenes/cornell-box.toml");
    let overrides = [("render.width", "64"), ("render.height", "64"), ("gi.mode", "\"none\"")];
    let scene = load(&path, &overrides);
    let image = trace(&scene, 256, 7, Some(0), false);
    let ctx = context();
    let mut r = Renderer::new(&ctx, scene.clone()).expect("renderer");
    r.render(scene.settings.time, true).expect("frame");
    let raster = r.output();
    drop(r);
    assert_no_validation_messages(&ctx);
    let n = (image.width * image.height) as usize;
    let (mut far, mut sum_ref, mut sum_raster) = (0usize, 0.0f64, 0.0f64);
    for i in 0..n {
        for c in 0..3 {
            let pt = image.mean[i * 3 + c] as f64;
            let sigma = (image.variance[i * 3 + c] as f64).sqrt();
            let ras = raster.radiance[i * 4 + c] as f64;
            sum_ref += pt;
            sum_raster += ras;
            if (pt - ras).abs() > 4.0 * sigma + 0.02 * pt.max(ras) + 1e-4 {
                far += 1;
            }
        }
    }
    let rel = (sum_raster - sum_ref).abs() / sum_ref;
    println!("image mean: rasterized {sum_raster:.3}, path traced {sum_ref:.3} ({:.2}%); {far} of {} values differ beyond noise", rel * 100.0, n * 3);
    assert!(rel < 0.01, "mean direct radiance differs by {:.2}%", rel * 100.0);
    // Only shadow edges (PCF against exact visibility) may differ: measured 33 of 12288.
    assert!(far * 100 < n * 3, "{far} of {} values differ beyond noise", n * 3);
}

/// `--specular first` in a glossy furnace: every face emits 1, reflects nothing diffusely and
/// has a Blinn-Phong lobe (Ks 0.5, exponent 20). With specular lobes at the first surface only,
/// the surfaces a path meets later only emit, so the image must equal the full transport cut
/// after one bounce (emission plus the lobe's reflection of it), and be darker than the full
/// transport, whose lobes reflect each other. On a Lambertian furnace it changes nothing.
#[test]
fn specular_at_the_first_surface_only_cuts_glossy_interreflection_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let glossy = furnace(dir.path(), [0.0; 3], [1.0; 3]);
    let text = std::fs::read_to_string(&glossy).unwrap().replace(
        "emission = [1.0, 1.0, 1.0]",
        "emission = [1.0, 1.0, 1.0]\nspecular = [0.5, 0.5, 0.5]\nshininess = 20",
    );
    std::fs::write(&glossy, text).unwrap();
    let scene = load(&glossy, &[]);
    let first = trace_with(&scene, 64, None, SpecularPaths::FirstSurface);
    let one_bounce = trace_with(&scene, 64, Some(1), SpecularPaths::All);
    let all = trace_with(&scene, 64, None, SpecularPaths::All);
    let mean = |i: &ReferenceImage| i.mean.iter().map(|&v| v as f64).sum::<f64>() / i.mean.len() as f64;
    let sigma = |i: &ReferenceImage| (i.variance.iter().map(|&v| v as f64).sum::<f64>()).sqrt() / i.mean.len() as f64;
    let (f, o, a) = (mean(&first), mean(&one_bounce), mean(&all));
    println!("glossy furnace: first surface {f:.5}, one bounce {o:.5}, all {a:.5}");
    assert!((f - o).abs() < 4.0 * (sigma(&first) + sigma(&one_bounce)), "first {f} against one bounce {o}");
    assert!(f > 1.05 && a > f + 10.0 * (sigma(&first) + sigma(&all)), "first {f}, all {a}");
    let lambert = load(&furnace(dir.path(), [0.5; 3], [1.0; 3]), &[]);
    let lf = mean(&trace_with(&lambert, 64, None, SpecularPaths::FirstSurface));
    assert!((lf - 2.0).abs() < 0.02, "a Lambertian furnace under --specular first: {lf}, expected 2");
}

fn trace_with(scene: &Scene, spp: u32, max_bounces: Option<u32>, specular: SpecularPaths) -> ReferenceImage {
    let ctx = context();
    let options = ReferenceOptions { spp, max_bounces, jitter: true, specular, ..Default::default() };
    let mut pt = PathTracer::new(&ctx, scene, options).expect("path tracer");
    pt.run(|_, _| {}).expect("trace");
    let image = pt.image().expect("read back");
    drop(pt);
    assert_no_validation_messages(&ctx);
    image
}

#[test]
fn empty_scene_traces_to_black() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.toml");
    std::fs::write(
        &path,
        "[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\n[render]\nwidth = 8\nheight = 8\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\n",
    )
    .unwrap();
    let image = trace(&load(&path, &[]), 2, 1, None, true);
    assert!(image.mean.iter().chain(&image.variance).all(|&v| v == 0.0));
}

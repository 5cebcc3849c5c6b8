//! Voxel cone-traced global illumination on the real device (lavapipe in CI, validation on):
//! colour bleeding, ambient occlusion, bounces, black without light, finite everywhere.

mod common;

use common::*;
use dvsgi::render::{FrameOutput, Renderer};
use dvsgi::scene::Scene;
use glam::Vec3;

const SIZE: &str = "64";

fn cornell(file: &str, overrides: &[(&str, &str)]) -> Scene {
    let mut all = vec![("render.width", SIZE), ("render.height", SIZE), ("gi.voxel_resolution", "32")];
    all.extend_from_slice(overrides);
    load(&repo().join("scenes").join(file), &all)
}

/// What each pixel sees: (material name, hit point, geometric normal), or None.
fn classify(scene: &Scene) -> Vec<Option<(String, Vec3, Vec3)>> {
    let tris = triangles(scene, 0.0);
    let (w, h) = (scene.settings.width, scene.settings.height);
    let mut out = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (o, d) = camera_ray(scene, x, y);
            out.push(raycast(&tris, o, d, 1e-4, 1e4).map(|(t, i)| {
                let tri = &tris[i];
                let n = (tri.b - tri.a).cross(tri.c - tri.a).normalize();
                (scene.materials[tri.material as usize].name.clone(), o + d * t, n)
            }));
        }
    }
    out
}

fn mean_radiance(out: &FrameOutput) -> f64 {
    out.radiance.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / out.radiance.len() as f64
}

/// White surfaces within 15 cm of the red (left) wall are measurably redder with GI than with
/// direct light only, and those near the green wall greener.
#[test]
fn gi_bleeds_colour_onto_white_surfaces_near_the_coloured_walls() {
    let ctx = context();
    let (direct, scene) = render(&ctx, cornell("cornell-box.toml", &[("gi.mode", "\"none\"")]));
    let (gi, _) = render(&ctx, cornell("cornell-box.toml", &[]));
    assert_colour_bleeding(&scene, &direct, &gi, "cone tracing");
}

/// The AO view is darker where the back wall meets the floor than in the middle of the back
/// wall, and with `gi.ao = true` (off by default) the final image is darker there.
#[test]
fn ambient_occlusion_darkens_corners() {
    let ctx = context();
    let (ao, scene) = render(&ctx, cornell("cornell-box.toml", &[("render.view", "\"ao\"")]));
    let seen = classify(&scene);
    // The back wall is the white plane facing -z at z = 0.56 m; the floor is at y = 0.
    let back = |i: usize| matches!(&seen[i], Some((m, _, n)) if m == "white" && n.z.abs() > 0.9);
    let corner = |i: usize| back(i) && matches!(&seen[i], Some((_, p, _)) if p.y < 0.04);
    let middle = |i: usize| {
        back(i) && matches!(&seen[i], Some((_, p, _)) if (0.2..0.35).contains(&p.y) && (0.2..0.35).contains(&p.x))
    };
    let (ao_corner, n_corner) = sum_where(&ao, corner);
    let (ao_middle, n_middle) = sum_where(&ao, middle);
    assert!(n_corner > 3 && n_middle > 3, "{n_corner} corner and {n_middle} middle pixels");
    let (ao_corner, ao_middle) = (ao_corner.x / n_corner as f32, ao_middle.x / n_middle as f32);
    assert!(ao_middle <= 1.0 && ao_corner >= 0.0);
    assert!(ao_corner < ao_middle - 0.1, "AO in the corner {ao_corner} vs the middle of the wall {ao_middle}");

    let (with, _) = render(&ctx, cornell("cornell-box.toml", &[("gi.ao", "true")]));
    let (without, _) = render(&ctx, cornell("cornell-box.toml", &[]));
    let (a, _) = sum_where(&with, corner);
    let (b, _) = sum_where(&without, corner);
    assert!(a.element_sum() < 0.97 * b.element_sum(), "corner radiance with AO {a} vs without {b}");
}

/// More bounces in one update never make the image darker, and the increments shrink
/// (converge).
#[test]
fn bounces_add_light_monotonically_and_converge() {
    let ctx = context();
    let means: Vec<f64> = (0..=4)
        .map(|b| {
            let bounces = b.to_string();
            let o = [("gi.bounces", bounces.as_str()), ("gi.bounce_feedback", "false")];
            mean_radiance(&render(&ctx, cornell("cornell-box.toml", &o)).0)
        })
        .collect();
    let steps: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).collect();
    // Voxelization order makes separate renders differ by a few 1/255 steps of albedo.
    let noise = 2e-3 * means[0];
    assert!(steps.iter().all(|&s| s > -noise), "bounces made the image darker: means {means:?}");
    assert!(steps[0] > 10.0 * noise, "the first bounce adds light: means {means:?}");
    assert!(steps[3] < 0.5 * steps[0], "bounces do not converge: means {means:?}");
}

/// Every float volume (all mip levels) and every cone-tracing target of a renderer.
fn all_float_data(r: &mut Renderer) -> Vec<(String, Vec<f32>)> {
    let mut out = Vec::new();
    for img in r.images() {
        for level in 0..img.desc.mip_levels {
            if let Some(t) = float_texels(r, &img, level) {
                out.push((format!("{} level {level}", img.name), t));
            }
        }
    }
    out
}

/// With zero light and no emission everything is exactly black: image, volumes, mips.
#[test]
fn no_light_gives_black_everywhere() {
    let ctx = context();
    let scene = cornell("cornell-box.toml", &[("lights.0.intensity", "[0, 0, 0]"), ("gi.bounces", "2")]);
    let mut r = Renderer::new(&ctx, scene).unwrap();
    r.render(0.0, true).unwrap();
    assert!(r.output().radiance.chunks_exact(4).all(|p| p[..3] == [0.0; 3]), "the image is not black");
    let data = all_float_data(&mut r);
    assert!(data.len() > 10, "volumes and targets read back: {}", data.len());
    for (name, texels) in data {
        // Radiance and directional volumes: rgb zero (alpha is occupancy); the diffuse target's
        // alpha is AO.
        assert!(texels.chunks_exact(4).all(|t| t[..3] == [0.0; 3]), "{name} is not black");
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// Every GI path at once (glossy materials and an emissive light, specular cones, cone
/// shadows, three bounces, half-resolution tracing): every float in every volume, mip,
/// target and the image is finite, and validation stays clean.
#[test]
fn every_gi_volume_and_image_is_finite() {
    let ctx = context();
    let scene = cornell(
        "cornell-glossy.toml",
        &[("gi.bounces", "3"), ("gi.shadows", "\"cone\""), ("gi.downsample", "2"), ("gi.diffuse_cones", "9")],
    );
    let mut r = Renderer::new(&ctx, scene).unwrap();
    r.render(0.0, true).unwrap();
    let names = r.pass_names(false);
    for p in ["voxel mips", "voxel bounce", "cone trace", "gi upsample"] {
        assert!(names.iter().any(|n| n.starts_with(p)), "{p} missing from {names:?}");
    }
    let out = r.output();
    assert!(out.radiance.iter().all(|v| v.is_finite()), "image has NaN/Inf");
    assert!(mean_radiance(&out) > 0.0);
    let data = all_float_data(&mut r);
    let names: Vec<&str> = data.iter().map(|(n, _)| n.as_str()).collect();
    for expected in [
        "voxel radiance bounced level 0",
        "voxel bounce scratch level 0",
        "voxel radiance -z level 3",
        "gi specular",
        "gi shadow (1/2)",
    ] {
        assert!(names.iter().any(|n| n.starts_with(expected)), "{expected} not read back: {names:?}");
    }
    for (name, texels) in data {
        assert!(texels.iter().all(|v| v.is_finite()), "{name} has NaN/Inf");
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// Tracing at reduced resolution and upsampling stays close to full-resolution tracing, and
/// closer at 1/2 than at 1/4.
#[test]
fn half_resolution_tracing_is_close_to_full_resolution() {
    let ctx = context();
    let indirect =
        |k: &str| render(&ctx, cornell("cornell-box.toml", &[("render.view", "\"indirect\""), ("gi.downsample", k)])).0;
    let full = indirect("1");
    let diff = |other: &FrameOutput| {
        full.radiance.iter().zip(&other.radiance).map(|(a, b)| (a - b).abs() as f64).sum::<f64>()
            / full.radiance.len() as f64
    };
    let (half, quarter) = (diff(&indirect("2")), diff(&indirect("4")));
    let mean = mean_radiance(&full);
    assert!(mean > 0.0);
    // At 64x64 silhouettes are a large share of the pixels.
    assert!(half < 0.15 * mean, "mean |full - half| = {half} vs mean indirect {mean}");
    assert!(half < quarter, "1/2 ({half}) should be closer to full resolution than 1/4 ({quarter})");
}

fn passes_run(r: &mut Renderer, t: f32) -> Vec<String> {
    r.render(t, false).unwrap();
    r.last_pass_names().to_vec()
}

/// The update policy: dynamic objects are revoxelized every N frames (or only on request);
/// a moving light alone relights without revoxelizing; a static view of a static light does
/// not relight.
#[test]
fn voxel_update_policy() {
    let ctx = context();
    let dynamic = |interval: &str, extra: &[(&str, &str)]| {
        let mut o = vec![("render.width", "16"), ("render.height", "16"), ("gi.voxel_resolution", "16")];
        o.push(("gi.update_interval", interval));
        o.extend_from_slice(extra);
        Renderer::new(&ctx, load(&repo().join("scenes/dynamic-test.toml"), &o)).unwrap()
    };
    let has = |names: &[String], p: &str| names.iter().any(|n| n == p);

    let mut r = dynamic("2", &[]);
    let frames: Vec<Vec<String>> = (0..3).map(|i| passes_run(&mut r, i as f32 * 0.1)).collect();
    assert!(has(&frames[0], "voxelize static") && has(&frames[0], "voxelize dynamic"));
    assert!(!has(&frames[1], "voxelize static") && !has(&frames[1], "voxelize dynamic"), "{:?}", frames[1]);
    assert!(!has(&frames[1], "voxel light"), "nothing changed, nothing relit: {:?}", frames[1]);
    assert!(has(&frames[2], "voxelize dynamic") && has(&frames[2], "voxel light"), "{:?}", frames[2]);
    assert!(frames.iter().all(|f| has(f, "cone trace")), "every frame traces cones");

    let mut r = dynamic("0", &[]);
    passes_run(&mut r, 0.0);
    assert!(!has(&passes_run(&mut r, 0.1), "voxelize dynamic"), "on demand: no update unasked");
    r.request_voxel_update();
    let asked = passes_run(&mut r, 0.2);
    assert!(has(&asked, "voxelize dynamic") && has(&asked, "voxel light"), "{asked:?}");

    // A moving light relights every frame without revoxelizing.
    let mut r = dynamic("0", &[("lights.0.motion", "{ velocity = [0.01, 0, 0] }")]);
    passes_run(&mut r, 0.0);
    let moved = passes_run(&mut r, 0.5);
    assert!(has(&moved, "voxel light") && !has(&moved, "voxelize dynamic"), "{moved:?}");
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// The voxel-mip view shows the radiance volumes at any level and direction: not black at the
/// full resolution and at fractional levels, darker in no direction than black, finite.
#[test]
fn voxel_mip_view_renders_every_level_and_direction() {
    let ctx = context();
    for (lod, dir) in [("0", "\"ray\""), ("1.5", "\"+x\""), ("3", "\"-y\""), ("5", "\"ray\"")] {
        let (out, _) = render(
            &ctx,
            cornell(
                "cornell-box.toml",
                &[("render.view", "\"voxel-mip\""), ("render.view_lod", lod), ("render.view_direction", dir)],
            ),
        );
        assert!(out.radiance.iter().all(|v| v.is_finite() && *v >= 0.0), "lod {lod} {dir}");
        assert!(mean_radiance(&out) > 0.0, "lod {lod} {dir} is black");
    }
}

/// The specular cone adds reflected light: the glossy Cornell box's indirect light is brighter
/// on average with `gi.specular` than without, over a clear set of pixels.
#[test]
fn specular_cone_adds_reflected_light_on_glossy_surfaces() {
    let ctx = context();
    let indirect = |spec: &str| {
        render(&ctx, cornell("cornell-glossy.toml", &[("render.view", "\"indirect\""), ("gi.specular", spec)])).0
    };
    let (with, without) = (indirect("true"), indirect("false"));
    let (a, b) = (mean_radiance(&with), mean_radiance(&without));
    assert!(a > 1.02 * b, "mean indirect with the specular cone {a} vs without {b}");
    let brighter = with.radiance.iter().zip(&without.radiance).filter(|(x, y)| *x > &(*y + 1e-3)).count();
    assert!(brighter > 20, "only {brighter} channels brighter with the specular cone");
}

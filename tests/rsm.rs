//! Reflective shadow maps (`gi.mode = "rsm"`) and light propagation volumes (`"lpv"`, built on
//! them) on the real device (lavapipe in CI, validation on): RSM's one bounce from a lit wall
//! onto a floor against the path tracer's for each kind of light, colour bleeding in the
//! Cornell box, black without light, nothing created for lights that cast no shadows; an LPV
//! propagation step on the GPU against the CPU reference and its energy in an empty grid, its
//! fuzzy occlusion (a plate between a lit wall and a receiver cuts the light as it cuts the path
//! tracer's one bounce), no negative radiance; finite everywhere and the same image in every
//! schedule for both.

mod common;

use common::*;
use dvsgi::reference::{PathTracer, ReferenceOptions};
use dvsgi::render::{FrameOutput, Mode, RenderOptions, Renderer};
use dvsgi::scene::{Aabb, Camera, GiMode, Light, LightKind, Material, Motion, Scene, View};
use glam::Vec3;
use glam::Vec4;

const SIZE: u32 = 48;

/// A white wall (z = 0, facing +z, 2 m square) standing on a white floor (y = 0, reaching 2 m
/// towards +z), lit by `light`, seen from above the floor.
fn wall_and_floor(light: LightKind) -> Scene {
    let wall = quad(Vec3::new(0.0, 1.0, 0.0), Vec3::X, Vec3::Y, Vec3::Z);
    let floor = quad(Vec3::new(0.0, 0.0, 1.0), Vec3::X, Vec3::Z, Vec3::Y);
    let mut s = scene_of(
        vec![mesh("wall", &wall, 0, None), mesh("floor", &floor, 1, None)],
        vec![Material::diffuse("wall", Vec3::splat(0.8)), Material::diffuse("floor", Vec3::splat(0.8))],
        Camera {
            position: Vec3::new(0.0, 1.6, 2.8),
            target: Vec3::new(0.0, 0.0, 1.0),
            up: Vec3::Y,
            fov_y_deg: 45.0,
            near: 0.01,
            far: 10.0,
        },
        vec![Light { name: "light".into(), kind: light, cast_shadows: true, motion: Motion::None }],
        Aabb { min: Vec3::new(-1.1, -0.1, -0.1), max: Vec3::new(1.1, 2.1, 2.1) },
    );
    s.settings.width = SIZE;
    s.settings.height = SIZE;
    s.settings.gi.mode = GiMode::Rsm;
    // Every texel of every map within reach of every pixel: the gather is then a complete
    // (stratified) sum over the lit surfaces.
    s.settings.gi.rsm_radius = 1.42;
    s.settings.gi.rsm_samples = 1024;
    s
}

/// The path tracer's radiance (RGB per pixel) with at most `bounces` indirect bounces.
fn reference(ctx: &std::sync::Arc<dvsgi::gpu::Context>, scene: &Scene, bounces: u32) -> Vec<f32> {
    let options = ReferenceOptions { spp: 512, max_bounces: Some(bounces), ..Default::default() };
    let mut pt = PathTracer::new(ctx, scene, options).unwrap();
    pt.run(|_, _| {}).unwrap();
    pt.image().unwrap().mean
}

/// Pixels that see the floor within `r` of its centre (0, 0, 1).
fn floor_centre(scene: &Scene, r: f32) -> Vec<usize> {
    let tris = triangles(scene, 0.0);
    (0..SIZE * SIZE)
        .filter(|&i| {
            let (o, d) = camera_ray(scene, i % SIZE, i / SIZE);
            raycast(&tris, o, d, 1e-4, 1e4).is_some_and(|(t, _)| {
                let p = o + d * t;
                p.y.abs() < 1e-3 && (p - Vec3::new(0.0, 0.0, 1.0)).length() < r
            })
        })
        .map(|i| i as usize)
        .collect()
}

/// A lit wall facing a white floor: the floor's indirect light at its centre is within 10% of
/// the path tracer's one-bounce indirect light (bounces 1 minus bounces 0) for a sun (the
/// whole-scene orthographic map), a spot light (one perspective map) and a point light (six
/// cube faces, each surface in one of them).
#[test]
fn a_lit_wall_lights_the_floor_as_the_reference_does() {
    let ctx = context();
    let lights = [
        ("sun", LightKind::Directional { direction: Vec3::NEG_Z, irradiance: Vec3::splat(3.0) }),
        (
            "spot",
            LightKind::Spot {
                position: Vec3::new(0.0, 1.2, 1.5),
                direction: Vec3::new(0.0, -0.1, -1.0),
                intensity: Vec3::splat(4.0),
                inner_deg: 30.0,
                outer_deg: 40.0,
            },
        ),
        ("point", LightKind::Point { position: Vec3::new(0.0, 1.2, 1.2), intensity: Vec3::splat(2.0) }),
    ];
    for (name, light) in lights {
        let scene = wall_and_floor(light);
        let patch = floor_centre(&scene, 0.2);
        assert!(patch.len() > 20, "{name}: only {} pixels on the floor's centre", patch.len());
        let one = reference(&ctx, &scene, 1);
        let direct = reference(&ctx, &scene, 0);
        let truth: f64 =
            patch.iter().map(|&i| (0..3).map(|c| (one[3 * i + c] - direct[3 * i + c]) as f64).sum::<f64>()).sum();
        let mut s = scene.clone();
        s.settings.view = View::Indirect;
        let (indirect, _) = render(&ctx, s);
        let rsm: f64 = patch.iter().map(|&i| (0..3).map(|c| indirect.radiance[4 * i + c] as f64).sum::<f64>()).sum();
        let ratio = rsm / truth;
        eprintln!("{name}: floor centre indirect RSM / reference = {ratio:.4} ({} px)", patch.len());
        assert!(truth > 0.0, "{name}: the reference has no indirect light on the floor");
        assert!((ratio - 1.0).abs() < 0.10, "{name}: RSM / reference one-bounce light = {ratio:.4}");
    }
}

/// One LPV propagation step on the GPU equals the CPU reference (`render::lpv::propagate_step`)
/// applied to the GPU's injected light, and in an empty grid (the lit wall in the middle of
/// bounds four times its size, so no light reaches the border in one step) it keeps the
/// injected flux within 0.1%.
#[test]
fn an_lpv_step_matches_the_cpu_reference_and_keeps_the_flux() {
    let ctx = context();
    let mut scene = wall_and_floor(LightKind::Directional { direction: Vec3::NEG_Z, irradiance: Vec3::splat(3.0) });
    scene.bounds = Some(Aabb { min: Vec3::splat(-4.0), max: Vec3::splat(4.0) });
    scene.settings.gi.mode = GiMode::Lpv;
    scene.settings.gi.lpv_resolution = 16;
    scene.settings.gi.lpv_steps = 1;
    scene.settings.gi.lpv_occlusion = false;
    let mut r = Renderer::new(&ctx, scene).unwrap();
    r.render(0.0, true).unwrap();
    let images = r.images();
    let mut read = |name: &str| -> Vec<Vec4> {
        let img = images.iter().find(|i| i.name == name).unwrap_or_else(|| panic!("no image {name}"));
        float_texels(&mut r, img, 0).unwrap().chunks_exact(4).map(Vec4::from_slice).collect()
    };
    for colour in ["r", "g", "b"] {
        let injected = read(&format!("lpv light a {colour}"));
        let stepped = read(&format!("lpv light b {colour}"));
        let flux = |g: &[Vec4]| g.iter().map(|v| dvsgi::render::lpv::flux(*v) as f64).sum::<f64>();
        assert!(flux(&injected) > 0.0, "{colour}: nothing injected");
        let cpu = dvsgi::render::lpv::propagate_step(&injected, 16);
        let scale = cpu.iter().map(|v| v.abs().max_element()).fold(0.0f32, f32::max);
        let worst = cpu.iter().zip(&stepped).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0f32, f32::max);
        assert!(worst <= 1e-5 * scale, "{colour}: GPU step differs from the CPU's by {worst} (largest {scale})");
        let kept = flux(&stepped) / flux(&injected);
        eprintln!("{colour}: one step keeps {kept:.6} of the injected flux");
        assert!((kept - 1.0).abs() < 1e-3, "{colour}: one step in an empty grid keeps {kept} of the flux");
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

fn cornell(overrides: &[(&str, &str)]) -> Scene {
    let mut all = vec![("render.width", "64"), ("render.height", "64"), ("gi.mode", "\"rsm\"")];
    all.extend_from_slice(overrides);
    load(&repo().join("scenes/cornell-box.toml"), &all)
}

/// White surfaces within 15 cm of the red (left) wall are redder with RSM light than with
/// direct light only, and those near the green wall greener (as tests/gi.rs asks of cones).
#[test]
fn rsm_bleeds_colour_onto_white_surfaces_near_the_coloured_walls() {
    let ctx = context();
    let (direct, scene) = render(&ctx, cornell(&[("gi.mode", "\"none\"")]));
    let (gi, _) = render(&ctx, cornell(&[]));
    assert_colour_bleeding(&scene, &direct, &gi, "RSM");
}

/// The RSM images and the gathered light as floats.
fn rsm_data(r: &mut Renderer) -> Vec<(String, Vec<f32>)> {
    let images = r.images();
    let mut out = Vec::new();
    for img in images.iter().filter(|i| ["rsm", "lpv", "gi "].iter().any(|p| i.name.starts_with(p))) {
        if let Some(t) = float_texels(r, img, 0) {
            out.push((img.name.clone(), t));
        }
    }
    out
}

/// With zero light everything is black: image, flux maps, gathered light.
#[test]
fn no_light_gives_black_everywhere() {
    let ctx = context();
    let mut r = Renderer::new(&ctx, cornell(&[("lights.0.intensity", "[0, 0, 0]"), ("gi.downsample", "2")])).unwrap();
    r.render(0.0, true).unwrap();
    assert!(r.output().radiance.chunks_exact(4).all(|p| p[..3] == [0.0; 3]), "the image is not black");
    let data = rsm_data(&mut r);
    let names: Vec<&str> = data.iter().map(|(n, _)| n.as_str()).collect();
    for expected in ["rsm flux", "gi diffuse (rsm, 1/2)", "gi diffuse (rsm)"] {
        assert!(names.contains(&expected), "{expected} not read back: {names:?}");
    }
    for (name, texels) in data.iter().filter(|(n, _)| n.starts_with("rsm flux") || n.starts_with("gi diffuse")) {
        assert!(texels.chunks_exact(4).all(|t| t[..3] == [0.0; 3]), "{name} is not black");
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// A light that casts no shadows has no shadow view and so no map: no RSM passes run, no RSM
/// image exists, and there is no indirect light.
#[test]
fn lights_without_shadows_get_no_maps() {
    let ctx = context();
    let mut r =
        Renderer::new(&ctx, cornell(&[("lights.0.cast_shadows", "false"), ("render.view", "\"indirect\"")])).unwrap();
    r.render(0.0, true).unwrap();
    let names = r.last_pass_names().to_vec();
    assert!(!names.iter().any(|n| n.contains("reflective") || n.starts_with("rsm")), "{names:?}");
    assert!(!r.images().iter().any(|i| i.name.starts_with("rsm")), "an RSM image exists");
    assert!(r.output().radiance.chunks_exact(4).all(|p| p[..3] == [0.0; 3]), "indirect light without a map");
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// A point light's six faces at half resolution with the upsample, gathered (RSM) and
/// propagated with occlusion (LPV): every float of every map, volume, gathered light and the
/// image is finite, the light the lighting pass reads is never negative (LPV's two-band SH
/// rings negative behind bright lobes; the lookup clamps), and the passes ran.
#[test]
fn every_map_volume_and_image_is_finite_and_the_light_never_negative() {
    let ctx = context();
    let passes = [
        ("rsm", vec!["reflective shadow maps", "rsm gather", "gi upsample"]),
        ("lpv", vec!["reflective shadow maps", "lpv inject", "lpv propagate", "lpv lookup", "gi upsample"]),
        ("rsm+lpv", vec!["rsm gather", "lpv inject", "lpv propagate", "lpv lookup", "gi add", "gi upsample"]),
    ];
    for (mode, expected) in passes {
        let m = format!("{mode:?}");
        let scene =
            cornell(&[("gi.mode", &m), ("gi.downsample", "2"), ("gi.rsm_size", "64"), ("gi.lpv_resolution", "16")]);
        let mut r = Renderer::new(&ctx, scene).unwrap();
        r.render(0.0, true).unwrap();
        let names = r.last_pass_names().to_vec();
        for p in expected {
            assert!(names.iter().any(|n| n == p), "{mode}: {p} missing from {names:?}");
        }
        let out: FrameOutput = r.output();
        assert!(out.radiance.iter().all(|v| v.is_finite()), "{mode}: image has NaN/Inf");
        let data = rsm_data(&mut r);
        assert!(data.len() >= 4, "{mode}: maps and targets read back: {}", data.len());
        for (name, texels) in &data {
            assert!(texels.iter().all(|v| v.is_finite()), "{mode}: {name} has NaN/Inf");
            if name.starts_with("gi diffuse") {
                assert!(texels.iter().all(|v| *v >= 0.0), "{mode}: {name} has negative light");
            }
        }
        drop(r);
    }
    assert_no_validation_messages(&ctx);
}

/// sync, async and async-lagged render the same RSM and LPV images, bit for bit, and the async
/// modes put the gather or the volume on the compute stream.
#[test]
fn every_mode_renders_the_same_rsm_and_lpv_image() {
    let ctx = context();
    for mode in ["\"rsm\"", "\"lpv\"", "\"rsm+lpv\""] {
        same_image_in_every_schedule(
            &ctx,
            cornell(&[("gi.mode", mode), ("gi.downsample", "2"), ("gi.rsm_size", "64"), ("gi.lpv_resolution", "16")]),
        );
    }
    assert_no_validation_messages(&ctx);
}

/// The study's mix: in the async modes the RSM gather goes to the compute queue and the light
/// propagation volume to the graphics queue, and the indirect light is the gather's near
/// field plus the volume's far field: less than the two techniques' lights added.
#[test]
fn the_mix_puts_the_gather_on_compute_and_the_volume_on_graphics() {
    let ctx = context();
    let overrides = |mode| {
        vec![("gi.mode", mode), ("gi.rsm_size", "64"), ("gi.lpv_resolution", "16"), ("render.view", "\"indirect\"")]
    };
    let options = RenderOptions { mode: Mode::Async, frames_in_flight: 2 };
    let mut r = Renderer::with_options(&ctx, cornell(&overrides("\"rsm+lpv\"")), options).unwrap();
    r.render(0.0, true).unwrap();
    let mix = r.output().radiance;
    let submits = r.scheduler().submits().to_vec();
    let on = |queue, pass: &str| submits.iter().any(|s| s.queue == queue && s.passes.iter().any(|p| p == pass));
    use dvsgi::render::graph::QueueKind::{Compute, Graphics};
    assert!(on(Compute, "rsm gather"), "{submits:?}");
    for p in ["lpv inject", "lpv propagate", "lpv lookup"] {
        assert!(on(Graphics, p), "{p}: {submits:?}");
    }
    r.wait_idle().unwrap();
    drop(r);
    let lum = |v: &[f32]| v.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>();
    let (rsm, _) = render(&ctx, cornell(&overrides("\"rsm\"")));
    let (lpv, _) = render(&ctx, cornell(&overrides("\"lpv\"")));
    assert!(lum(&mix) > 0.0);
    assert!(lum(&mix) < lum(&rsm.radiance) + lum(&lpv.radiance), "the mix counts light twice");
    assert_no_validation_messages(&ctx);
}

fn same_image_in_every_schedule(ctx: &std::sync::Arc<dvsgi::gpu::Context>, s: Scene) {
    let mut r = Renderer::with_options(ctx, s, RenderOptions { mode: Mode::Sync, frames_in_flight: 2 }).unwrap();
    r.render(0.0, true).unwrap();
    let sync = r.output().radiance;
    assert!(sync.iter().any(|v| *v > 0.0));
    for mode in [Mode::Async, Mode::AsyncLagged, Mode::Sync, Mode::Async] {
        r.set_mode(mode).unwrap();
        r.render(0.0, true).unwrap();
        let out = r.output().radiance;
        let differing = sync.iter().zip(&out).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{mode}: {differing} values differ from sync");
        if mode != Mode::Sync {
            let queues: Vec<_> = r.scheduler().submits().iter().map(|s| s.queue).collect();
            assert!(queues.contains(&dvsgi::render::graph::QueueKind::Compute), "{mode}: {queues:?}");
        }
    }
    r.wait_idle().unwrap();
}

/// A white wall (x = 0, facing +x, 2 m square), a white receiver facing it 1 m away (x = 1)
/// and, if `blocker`, a white 1 m square plate halfway between them (x = 0.5), lit by a point
/// light between the wall and the plate. The camera stands between the plate and the receiver
/// and looks at the receiver.
fn wall_blocker_receiver(blocker: bool) -> Scene {
    let wall = quad(Vec3::new(0.0, 1.0, 0.0), Vec3::Y, Vec3::Z, Vec3::X);
    let receiver = quad(Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::Z, Vec3::NEG_X);
    let plate = quad(Vec3::new(0.5, 1.0, 0.0), 0.5 * Vec3::Y, 0.5 * Vec3::Z, Vec3::NEG_X);
    let mut meshes = vec![mesh("wall", &wall, 0, None), mesh("receiver", &receiver, 0, None)];
    if blocker {
        meshes.push(mesh("blocker", &plate, 0, None));
    }
    let mut s = scene_of(
        meshes,
        vec![Material::diffuse("white", Vec3::splat(0.8))],
        Camera {
            position: Vec3::new(0.7, 1.0, 0.0),
            target: Vec3::new(1.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y_deg: 90.0,
            near: 0.01,
            far: 10.0,
        },
        vec![Light {
            name: "light".into(),
            kind: LightKind::Point { position: Vec3::new(0.25, 1.0, 0.0), intensity: Vec3::splat(1.0) },
            cast_shadows: true,
            motion: Motion::None,
        }],
        Aabb { min: Vec3::new(-0.53125, 0.0, -1.0), max: Vec3::new(1.46875, 2.0, 1.0) },
    );
    s.settings.width = SIZE;
    s.settings.height = SIZE;
    s.settings.view = View::Indirect;
    s.settings.gi.mode = GiMode::Lpv;
    s.settings.gi.lpv_resolution = 16;
    s.settings.gi.rsm_size = 64;
    s
}

/// Pixels that see the receiver (x = 1) within `r` of its centre (1, 1, 0).
fn receiver_centre(scene: &Scene, r: f32) -> Vec<usize> {
    let tris = triangles(scene, 0.0);
    (0..SIZE * SIZE)
        .filter(|&i| {
            let (o, d) = camera_ray(scene, i % SIZE, i / SIZE);
            raycast(&tris, o, d, 1e-4, 1e4).is_some_and(|(t, _)| {
                let p = o + d * t;
                (p.x - 1.0).abs() < 1e-3 && (p - Vec3::new(1.0, 1.0, 0.0)).length() < r
            })
        })
        .map(|i| i as usize)
        .collect()
}

/// LPV's fuzzy occlusion: a plate between a lit wall and a receiver cuts the propagated light
/// reaching the receiver's centre, as it cuts the path tracer's one bounce there (bounces 1
/// minus bounces 0). The plate is lit on its wall side, so the reflective shadow map puts it in
/// the geometry volume.
///
/// Measured (lavapipe, 48x48, 16 cells, 64x64 maps, 512 spp; sums over the 1264 pixels within
/// 25 cm of the receiver's centre):
///
/// | | without the plate | with the plate | with / without |
/// |---|---|---|---|
/// | reference one bounce | 858.8 | 6.59 | 0.0077 |
/// | LPV | 691.1 | 10.40 | 0.0151 |
/// | LPV, `gi.lpv_occlusion = false` | 808.5 | 81.34 | 0.1006 |
///
/// Without occlusion the plate still cuts the light tenfold: its own lobes, lit from the wall's
/// side, are negative towards the receiver (two-band SH) and cancel part of the wall's light.
/// The occlusion term does the rest (81.3 to 10.4), so the bounds sit between the two: the
/// plate must cut LPV's light to less than 4% (0.0151 measured, 0.10 with the fuzzy-occlusion
/// term made zero in lpv_propagate.comp), and occlusion must remove more than three quarters of
/// what reaches the receiver behind the plate (0.128 kept measured, 1 with the term zero).
#[test]
fn a_blocker_between_a_lit_wall_and_a_receiver_cuts_the_lpv_light() {
    let ctx = context();
    let sum = |v: &[f32], stride: usize, patch: &[usize]| -> f64 {
        patch.iter().map(|&i| (0..3).map(|c| v[stride * i + c] as f64).sum::<f64>()).sum()
    };
    // [without, with] the plate.
    let (mut truth, mut lpv, mut unoccluded) = (vec![], vec![], vec![]);
    for blocker in [false, true] {
        let scene = wall_blocker_receiver(blocker);
        let patch = receiver_centre(&scene, 0.25);
        assert!(patch.len() > 500, "only {} pixels on the receiver's centre", patch.len());
        let one_bounce = sum(&reference(&ctx, &scene, 1), 3, &patch) - sum(&reference(&ctx, &scene, 0), 3, &patch);
        let (on, _) = render(&ctx, scene.clone());
        let mut s = scene;
        s.settings.gi.lpv_occlusion = false;
        let (off, _) = render(&ctx, s);
        let (on, off) = (sum(&on.radiance, 4, &patch), sum(&off.radiance, 4, &patch));
        eprintln!(
            "plate {blocker}: {} px, reference one bounce {one_bounce:.4}, LPV {on:.4}, without occlusion {off:.4}",
            patch.len()
        );
        truth.push(one_bounce);
        lpv.push(on);
        unoccluded.push(off);
    }
    let ratio = |v: &[f64]| v[1] / v[0];
    eprintln!(
        "with / without the plate: reference {:.4}, LPV {:.4}, LPV without occlusion {:.4}",
        ratio(&truth),
        ratio(&lpv),
        ratio(&unoccluded)
    );
    assert!(truth[0] > 0.0 && ratio(&truth) < 0.05, "the reference's plate does not shade the receiver: {truth:?}");
    let open = lpv[0] / truth[0];
    assert!((0.5..2.0).contains(&open), "without the plate LPV / reference one bounce = {open:.4}");
    assert!(
        ratio(&lpv) < 0.04,
        "the plate cuts LPV's light only to {:.4} (reference {:.4})",
        ratio(&lpv),
        ratio(&truth)
    );
    let kept = lpv[1] / unoccluded[1];
    assert!(
        kept < 0.25,
        "behind the plate, occlusion keeps {kept:.4} of the light (LPV {:.4} without it)",
        unoccluded[1]
    );
}

/// The reflective shadow maps, and the light propagation volume injected from them, are drawn
/// only when what they are drawn from changed (a light, a view, a caster): a camera that moves
/// reuses them, a light that moves redraws them. Every frame is the image a new renderer makes
/// of the same scene, in the async schedule with two frames in flight.
#[test]
fn reflective_shadow_maps_are_redrawn_only_when_a_light_or_a_caster_moves() {
    let ctx = context();
    let base = cornell(&[("gi.mode", "\"rsm+lpv\""), ("gi.rsm_size", "64"), ("gi.lpv_resolution", "16")]);
    let options = RenderOptions { mode: Mode::Async, frames_in_flight: 2 };
    let mut r = Renderer::with_options(&ctx, base.clone(), options).unwrap();
    // (camera moved, light moved, the maps drawn)
    let frames = [(0.0, 0.0, true), (0.0, 0.0, false), (0.05, 0.0, false), (0.05, 0.03, true), (0.05, 0.03, false)];
    for (i, &(camera, light, drawn)) in frames.iter().enumerate() {
        let mut s = base.clone();
        s.camera.position.x += camera;
        match &mut s.lights[0].kind {
            LightKind::Point { position, .. } | LightKind::Spot { position, .. } => position.x += light,
            LightKind::Directional { .. } => unreachable!("the Cornell box's light is a point or spot light"),
        }
        (r.scene.camera, r.scene.lights) = (s.camera.clone(), s.lights.clone());
        r.render(0.0, true).unwrap();
        let names = r.last_pass_names();
        for p in ["reflective shadow maps", "lpv inject", "lpv propagate"] {
            assert_eq!(names.iter().any(|n| n == p), drawn, "frame {i}: {p} in {names:?}");
        }
        for p in ["rsm gather", "lpv lookup", "gi add"] {
            assert!(names.iter().any(|n| n == p), "frame {i}: {p} missing from {names:?}");
        }
        let image = r.output().radiance;
        let (redrawn, _) = render(&ctx, s);
        assert!(image == redrawn.radiance, "frame {i}: the image differs from a new renderer's");
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

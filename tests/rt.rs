//! Ray tracing on the real device under validation. Reflections (`gi.specular = "rt"`): a
//! mirror reflects a lit wall by the BRDF's specular reflectance, an alpha mask lets the
//! reflection through where it cuts, empty space reflects black, a moving object is seen in the
//! mirror in the frame it moves, every schedule mode renders the same image, and glossy
//! reflections average their rays over the frames the view stands still; on the mirror Cornell
//! box, with the reflected light made exact in both, the rays' mirror is the path tracer's
//! within 5%. Shadows
//! (`gi.shadows = "rt"`): the direct light of the Cornell box is the path tracer's, pixel for
//! pixel, in every schedule mode (tests/maps.rs checks an alpha-masked occluder). Devices
//! without ray queries refuse `rt` with one line.

mod common;

use common::*;
use dvsgi::metrics::LinearImage;
use dvsgi::reference::{PathTracer, ReferenceOptions, SpecularPaths};
use dvsgi::regions::{region_stats, Grouping, Pair, RegionMap};
use dvsgi::render::{Mode, RenderOptions, Renderer};
use dvsgi::scene::*;
use glam::{Mat4, Vec2, Vec3};
use std::f32::consts::PI;
use std::path::PathBuf;

const KS: f32 = 0.95;
const SHININESS: f32 = 1000.0;
const WALL_ALBEDO: f32 = 0.8;
const IRRADIANCE: f32 = 2.0;

const UV: [Vec2; 4] = [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];

/// A black mirror (Ks 0.95, exponent 1000) on the floor (y = 0, x and z in -1..1) and, behind
/// it, a white wall (z = -1.5, x in -2..2, y in 0..6) facing it, lit head-on by a sun of
/// irradiance 2 that does not reach the mirror. The camera looks steeply down at the mirror,
/// which reflects the wall.
fn mirror_scene() -> Scene {
    let v = Vec3::new;
    let mirror = uv_quad("mirror", [v(-1., 0., 1.), v(1., 0., 1.), v(1., 0., -1.), v(-1., 0., -1.)], UV, Vec3::Y, 0);
    let wall = uv_quad("wall", [v(-2., 0., -1.5), v(2., 0., -1.5), v(2., 6., -1.5), v(-2., 6., -1.5)], UV, Vec3::Z, 1);
    let mut glass = Material::diffuse("mirror", Vec3::ZERO);
    glass.specular = Vec3::splat(KS);
    glass.shininess = SHININESS;
    let camera = Camera {
        position: v(0.0, 3.0, 1.0),
        target: v(0.0, 0.0, 0.0),
        up: Vec3::Y,
        fov_y_deg: 40.0,
        near: 0.1,
        far: 30.0,
    };
    let sun = Light {
        name: "sun".into(),
        kind: LightKind::Directional { direction: v(0.0, 0.0, -1.0), irradiance: Vec3::splat(IRRADIANCE) },
        cast_shadows: false,
        motion: Motion::None,
    };
    let mut s = scene_of(
        vec![mirror, wall],
        vec![glass, Material::diffuse("wall", Vec3::splat(WALL_ALBEDO))],
        camera,
        vec![sun],
        Aabb { min: v(-3., -1., -3.), max: v(3., 7., 3.) },
    );
    s.settings.width = 48;
    s.settings.height = 48;
    s.settings.gi.specular = SpecularSource::Rt;
    s
}

/// The mirror point a pixel sees, the cosine of its view angle, and where its reflection
/// meets the wall's plane.
fn reflection_at(scene: &Scene, x: u32, y: u32) -> (Vec3, f32, Vec3) {
    let (o, d) = camera_ray(scene, x, y);
    let p = o + d * (-o.y / d.y);
    let r = Vec3::new(d.x, -d.y, d.z);
    let hit = p + r * ((-1.5 - p.z) / r.z);
    (p, -d.y, hit)
}

fn has_ray_queries(ctx: &dvsgi::gpu::Context) -> bool {
    if !ctx.info.optional.ray_query {
        println!("skipped: {} has no ray queries", ctx.info.name);
    }
    ctx.info.optional.ray_query
}

/// Radiance at the pixel that sees the mirror's centre.
fn mirror_centre(out: &dvsgi::render::FrameOutput, scene: &Scene) -> Vec3 {
    let (x, y) = project(scene, Vec3::ZERO);
    Vec3::from(out.radiance_at(x, y))
}

#[test]
fn a_mirror_reflects_a_lit_wall_by_its_specular_reflectance() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let wall = WALL_ALBEDO * IRRADIANCE / PI;
    let mut cone_scene = mirror_scene();
    cone_scene.settings.gi.specular = SpecularSource::Cone;
    let (cone, _) = render(&ctx, cone_scene);
    // Either source of the hits' indirect light: the wall has none to speak of (the mirror is
    // black to the voxels), so both see its direct light.
    for hit in [HitIndirect::Voxel, HitIndirect::Cones] {
        let mut s = mirror_scene();
        s.settings.gi.rt_hit_indirect = hit;
        let (out, s) = render(&ctx, s);
        assert_reflects_the_wall(&s, &out, &cone, wall);
    }
    assert_no_validation_messages(&ctx);
}

fn assert_reflects_the_wall(s: &Scene, out: &dvsgi::render::FrameOutput, cone: &dvsgi::render::FrameOutput, wall: f32) {
    let mut checked = 0;
    for y in 0..s.settings.height {
        for x in 0..s.settings.width {
            let (p, c, hit) = reflection_at(s, x, y);
            // Mirror pixels away from its edges whose reflection lands well inside the wall.
            let inside = p.x.abs() < 0.8 && p.z.abs() < 0.8 && hit.x.abs() < 1.5 && (0.5..5.5).contains(&hit.y);
            if !inside {
                continue;
            }
            // Blinn-Phong's directional albedo for a sharp lobe: Ks (n+8)/(n+1) cos^2.
            let expected = KS * (SHININESS + 8.0) / (SHININESS + 1.0) * c * c * wall;
            let got = Vec3::from(out.radiance_at(x, y));
            let cone_got = Vec3::from(cone.radiance_at(x, y));
            let err = (got - Vec3::splat(expected)).abs().max_element() / expected;
            assert!(err <= 0.02, "pixel ({x}, {y}): {got} vs {expected} ({:.1}%)", err * 100.0);
            if checked == 0 {
                let hit = s.settings.gi.rt_hit_indirect;
                println!("rays ({hit:?} at hits) {got}, cone {cone_got}, expected {expected} (cos {c})");
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} pixels see the wall in the mirror");
}

#[test]
fn an_alpha_mask_lets_the_reflection_through_where_it_cuts() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let mut s = mirror_scene();
    // The wall is there only where x < 0 (u < 0.5).
    s.materials[1].mask_texture = Some(0);
    let rgba8 = (0..64u32 * 64).flat_map(|i| [if i % 64 < 32 { 255 } else { 0 }; 4]).collect();
    s.textures = vec![Texture { path: PathBuf::from("mask"), width: 64, height: 64, rgba8, usage: TextureUse::Mask }];
    let (out, s) = render(&ctx, s);
    let (mut kept, mut cut) = (0, 0);
    for y in 0..s.settings.height {
        for x in 0..s.settings.width {
            let (p, c, hit) = reflection_at(&s, x, y);
            if p.x.abs() > 0.8 || p.z.abs() > 0.8 || !(0.5..5.5).contains(&hit.y) {
                continue;
            }
            let got = Vec3::from(out.radiance_at(x, y)).max_element();
            let wall = KS * c * c * WALL_ALBEDO * IRRADIANCE / PI;
            if (-1.5..-0.3).contains(&hit.x) {
                assert!(got > 0.9 * wall, "({x}, {y}) should reflect the wall: {got} vs {wall}");
                kept += 1;
            } else if (0.3..1.5).contains(&hit.x) {
                assert!(got < 0.02 * wall, "({x}, {y}) should see through the cut: {got}");
                cut += 1;
            }
        }
    }
    assert!(kept >= 10 && cut >= 10, "kept {kept}, cut {cut}");
    assert_no_validation_messages(&ctx);
}

#[test]
fn a_mirror_facing_empty_space_reflects_black() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let mut s = mirror_scene();
    s.objects.truncate(1); // the mirror alone
    let (out, s) = render(&ctx, s);
    let centre = mirror_centre(&out, &s);
    assert_eq!(centre, Vec3::ZERO, "the mirror reflects nothing: {centre}");
    assert_no_validation_messages(&ctx);
}

#[test]
fn a_moving_object_is_in_the_mirror_in_the_frame_it_moves() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let mut s = mirror_scene();
    let v = Vec3::new;
    // A red panel in front of the wall where the mirror's centre reflects it, moving out of
    // the way between t = 0 and t = 1 (keyframes clamp at the ends).
    let (x, y) = project(&s, Vec3::ZERO);
    let (p, _, hit) = reflection_at(&s, x, y);
    let c = p + (hit - p) * ((-1.2 - p.z) / (hit.z - p.z));
    let panel = uv_quad(
        "panel",
        [c + v(-0.6, -0.6, 0.0), c + v(0.6, -0.6, 0.0), c + v(0.6, 0.6, 0.0), c + v(-0.6, 0.6, 0.0)],
        UV,
        Vec3::Z,
        2,
    );
    s.meshes.push(panel);
    s.materials.push(Material::diffuse("red", v(0.9, 0.05, 0.05)));
    let key =
        |time: f32, x: f32| Keyframe { time, translate: v(x, 0.0, 0.0), rotate_deg: Vec3::ZERO, scale: Vec3::ONE };
    s.objects.push(Object {
        name: "panel".into(),
        meshes: vec![2],
        transform: Mat4::IDENTITY,
        dynamic: true,
        motion: Motion::Keyframes(vec![key(0.0, 0.0), key(1.0, 2.5)]),
    });
    let mut r = Renderer::new(&ctx, s.clone()).expect("renderer");
    r.render(0.0, true).expect("frame at t = 0");
    let before = mirror_centre(&r.output(), &s);
    r.render(1.0, true).expect("frame at t = 1");
    let after = mirror_centre(&r.output(), &s);
    r.render(0.0, true).expect("frame back at t = 0");
    let back = mirror_centre(&r.output(), &s);
    drop(r);
    println!("mirror centre: panel in front {before}, moved away {after}, back {back}");
    assert!(before.x > 4.0 * before.y, "the red panel is in the mirror: {before}");
    assert!((after.x - after.y).abs() < 0.1 * after.x, "the wall, white, is in the mirror: {after}");
    assert!(back.x > 4.0 * back.y, "the panel is back in the mirror: {back}");
    assert_no_validation_messages(&ctx);
}

#[test]
fn every_schedule_mode_renders_the_same_reflections() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let s = mirror_scene();
    let t = s.settings.time;
    let mut r = Renderer::with_options(&ctx, s, RenderOptions { mode: Mode::Sync, frames_in_flight: 2 }).unwrap();
    r.render(t, true).unwrap();
    let sync = r.output().radiance;
    for mode in [Mode::Async, Mode::AsyncLagged] {
        r.set_mode(mode).unwrap();
        r.render(t, true).unwrap();
        assert!(r.output().radiance == sync, "{mode} differs from sync");
        assert!(r.last_pass_names().iter().any(|n| n == "rt reflections"), "{mode}: {:?}", r.last_pass_names());
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

#[test]
fn rt_needs_ray_queries_and_says_so() {
    let ctx = context();
    let mut reflections = mirror_scene();
    reflections.settings.gi.specular = SpecularSource::Rt;
    let mut shadows = mirror_scene();
    shadows.settings.gi.specular = SpecularSource::Cone;
    shadows.settings.gi.shadows = DirectShadows::Rt;
    for (s, alternative) in [(reflections, "gi.specular = \"cone\""), (shadows, "gi.shadows = \"shadow-map\"")] {
        match Renderer::new(&ctx, s) {
            Ok(_) => assert!(ctx.info.optional.ray_query, "rendered rt without ray queries"),
            Err(e) => {
                assert!(!ctx.info.optional.ray_query, "refused with ray queries: {e}");
                let msg = e.to_string();
                assert!(msg.contains("VK_KHR_ray_query") && msg.contains(alternative), "{msg}");
                assert_eq!(msg.lines().count(), 1, "{msg}");
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// The study's comparison on the mirror Cornell box (the tall block: Ks 0.95, exponent 1000),
/// with the light at the reflected surfaces made the same in both renderers: one bounce
/// (`gi.bounces = 0` renders what the path tracer's `--bounces 1` traces, the reflected surfaces
/// lit by the lights alone) and specular lobes at the first surface only (the renderer's
/// transport). What is left in the mirror's region is the reflection's own error: within 5%
/// with rays. The cone's is printed beside it (ACCURACY.md: 24% too bright at 256x256).
#[test]
fn the_mirror_box_reflects_its_light_within_five_percent_with_rays() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let setup = [("render.width", "64"), ("render.height", "64"), ("gi.bounces", "0")];
    let scene = common::load(&repo().join("scenes/cornell-mirror.toml"), &setup);
    let options = ReferenceOptions {
        spp: 256,
        max_bounces: Some(1),
        specular: SpecularPaths::FirstSurface,
        ..Default::default()
    };
    let mut pt = PathTracer::new(&ctx, &scene, options).expect("path tracer");
    pt.run(|_, _| {}).expect("trace");
    let reference = pt.image().expect("read back");
    drop(pt);
    let reference = LinearImage { width: 64, height: 64, rgb: reference.mean };
    let map = RegionMap::trace(&scene, 64, 64);
    let mirror_ratio = |specular: SpecularSource| {
        let mut s = scene.clone();
        s.settings.gi.specular = specular;
        let (out, _) = render(&ctx, s);
        let rgb = out.radiance.chunks(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        let test = LinearImage { width: 64, height: 64, rgb };
        let pair = Pair { test: &test, reference: &reference, reference_variance: None };
        let stats = region_stats(&map, &pair);
        let mirror =
            stats.iter().find(|r| r.grouping == Grouping::Material && r.name == "tallBox").expect("the mirror");
        (mirror.ratio, mirror.pixels)
    };
    let (rays, pixels) = mirror_ratio(SpecularSource::Rt);
    let (cone, _) = mirror_ratio(SpecularSource::Cone);
    println!("the mirror ({pixels} pixels) against the reference: rays {rays:.4}, cone {cone:.4}");
    assert!(pixels > 200, "the mirror covers {pixels} pixels");
    assert!((rays - 1.0).abs() <= 0.05, "the rays' mirror is {rays:.4} of the reference");
    assert_no_validation_messages(&ctx);
}

/// The Cornell box's direct light (`gi.mode = "none"`) at 64x64, rendered with shadow maps and
/// with shadow rays, and traced by the path tracer with no bounces through the pixel centres
/// (one path per pixel is exact: a point light, no randomness left). The fraction of pixels
/// off the reference by more than 2% (the G-buffer's 8-bit albedo is within 0.5%).
#[test]
fn shadow_rays_give_the_path_tracers_direct_light_in_every_schedule_mode() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let size = [("render.width", "64"), ("render.height", "64"), ("gi.mode", "\"none\"")];
    let scene = common::load(&repo().join("scenes/cornell-box.toml"), &size);
    let options = ReferenceOptions { spp: 1, max_bounces: Some(0), ..Default::default() };
    let mut pt = PathTracer::new(&ctx, &scene, options).expect("path tracer");
    pt.run(|_, _| {}).expect("trace");
    let reference = pt.image().expect("read back").mean;
    drop(pt);
    let off = |out: &[f32]| {
        let bad = (0..reference.len() / 3)
            .filter(|&i| {
                (0..3).any(|c| (out[4 * i + c] - reference[3 * i + c]).abs() > 0.02 * reference[3 * i + c] + 1e-3)
            })
            .count();
        bad as f64 / (reference.len() / 3) as f64
    };
    let (maps, _) = render(&ctx, scene.clone());
    let mut rays = scene;
    rays.settings.gi.shadows = DirectShadows::Rt;
    let t = rays.settings.time;
    let mut r = Renderer::with_options(&ctx, rays, RenderOptions { mode: Mode::Sync, frames_in_flight: 2 }).unwrap();
    r.render(t, true).unwrap();
    let sync = r.output().radiance;
    println!(
        "pixels off the reference by > 2%: shadow maps {:.2}%, rays {:.2}%",
        100.0 * off(&maps.radiance),
        100.0 * off(&sync)
    );
    assert!(off(&sync) <= 0.001, "{:.2}% of the pixels are off", 100.0 * off(&sync));
    for mode in [Mode::Async, Mode::AsyncLagged] {
        r.set_mode(mode).unwrap();
        r.render(t, true).unwrap();
        assert!(r.output().radiance == sync, "{mode} differs from sync");
        let names = r.last_pass_names();
        assert!(names.iter().any(|n| n == "rt shadows") && !names.iter().any(|n| n == "shadow maps"), "{names:?}");
    }
    drop(r);
    // With voxel GI the maps still light the voxels, but only on the frames that relight them
    // (here only the first: `gi.update_interval = 0`).
    let mut vct = common::load(&repo().join("scenes/cornell-box.toml"), &size[..2]);
    (vct.settings.gi.shadows, vct.settings.gi.voxel_resolution) = (DirectShadows::Rt, 32);
    vct.settings.gi.update_interval = 0;
    let mut r = Renderer::new(&ctx, vct).unwrap();
    let mut maps_per_frame = Vec::new();
    for _ in 0..3 {
        r.render(t, false).unwrap();
        maps_per_frame.push(r.last_pass_names().iter().any(|n| n == "shadow maps"));
    }
    drop(r);
    assert_eq!(maps_per_frame, [true, false, false], "frames that render the shadow maps");
    assert_no_validation_messages(&ctx);
}

#[test]
fn an_empty_top_level_builds_without_error() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    // No instances at all: the build and the structure are valid, and a ray query through it
    // finds nothing (the renderer never makes one: a scene without a glossy surface traces no
    // reflections, and the mirror itself is an instance).
    let top = dvsgi::gpu::accel::TopLevel::new(&ctx, "empty top level", 0).expect("top level");
    ctx.one_shot("build an empty top level", |cmd| top.record_build(&ctx, cmd)).expect("build");
    assert_eq!(top.count, 0);
    drop(top);
    assert_no_validation_messages(&ctx);
}

/// The mirror scene with a glossy floor (exponent 40) and one ray per pixel: each frame's
/// reflection is noisy where the lobe straddles the wall's edge.
fn glossy_scene(history: u32, rays: u32) -> Scene {
    let mut s = mirror_scene();
    s.materials[0].shininess = 40.0;
    s.settings.gi.specular_rays = rays;
    s.settings.gi.specular_history = history;
    s
}

/// Mean squared difference of two radiance images.
fn mse(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum::<f64>() / a.len() as f64
}

/// `frames` frames of `s` (scene time fixed) and the radiance of the last.
fn radiance_after(r: &mut Renderer, frames: u32) -> Vec<f32> {
    for _ in 1..frames {
        r.render(0.0, false).unwrap();
    }
    r.render(0.0, true).unwrap();
    r.output().radiance
}

#[test]
fn glossy_reflections_average_their_rays_while_the_view_stands_still_and_start_again_when_it_moves() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let reference = |s: Scene| {
        let mut r = Renderer::new(&ctx, s).unwrap();
        radiance_after(&mut r, 2)
    };
    let truth = reference(glossy_scene(1, 64));
    let mut r = Renderer::new(&ctx, glossy_scene(16, 1)).unwrap();
    // Two frames (the voxels' light needs one to settle), then 16: the noise's variance an
    // eighth (a quarter allows for the voxels' own run-to-run noise and the 64-ray truth's).
    let two = mse(&radiance_after(&mut r, 2), &truth);
    let sixteen = mse(&radiance_after(&mut r, 14), &truth);
    assert!(sixteen < two / 4.0, "16 frames {sixteen:.3e} against two {two:.3e}");
    // The camera moves: the history starts again, as noisy as one frame.
    r.scene.camera.position.x += 0.05;
    let moved_truth = {
        let mut s = glossy_scene(1, 64);
        s.camera.position.x += 0.05;
        reference(s)
    };
    let moved = mse(&radiance_after(&mut r, 1), &moved_truth);
    assert!(moved > sixteen * 4.0, "after the move {moved:.3e}, before {sixteen:.3e}");
    // Without a history, frames stay as noisy as the first.
    let mut single = Renderer::new(&ctx, glossy_scene(1, 1)).unwrap();
    let still = mse(&radiance_after(&mut single, 16), &truth);
    println!("MSE against 64 rays: two frames {two:.3e}, 16 frames {sixteen:.3e}, after a move {moved:.3e}, 16 frames without history {still:.3e}");
    assert!(still > sixteen * 4.0, "16 frames without history {still:.3e}, with {sixteen:.3e}");
    drop((r, single));
    assert_no_validation_messages(&ctx);
}

/// The mirror scene with the wall out of the sun (it travels along (0.3, -1, 0), parallel to
/// the wall's plane) and a white floor under the mirror that the sun lights: all the wall's light
/// is the floor's, reflected once by the wall, whose albedo is coloured, (0.8, 0.4, 0.2). The
/// voxel grid (8 m, 32 voxels) is placed so that the wall lies in the middle of a voxel layer: a
/// hit's voxel lookup steps a quarter voxel behind the surface, which from a wall on a voxel's
/// face lands in the empty layer behind it.
fn wall_lit_by_its_floor() -> Scene {
    let v = Vec3::new;
    let mut s = mirror_scene();
    let corners = [v(-3., -0.02, 3.), v(3., -0.02, 3.), v(3., -0.02, -1.5), v(-3., -0.02, -1.5)];
    s.meshes.push(uv_quad("floor", corners, UV, Vec3::Y, 2));
    s.materials.push(Material::diffuse("floor", Vec3::splat(WALL_ALBEDO)));
    let floor = Object {
        name: "floor".into(),
        meshes: vec![2],
        transform: Mat4::IDENTITY,
        dynamic: false,
        motion: Motion::None,
    };
    s.objects.push(floor);
    s.materials[1].albedo = v(0.8, 0.4, 0.2);
    let direction = v(0.3, -1.0, 0.0).normalize();
    s.lights[0].kind = LightKind::Directional { direction, irradiance: Vec3::splat(IRRADIANCE) };
    s.bounds = Some(Aabb { min: v(-3., -1., -3.25), max: v(3., 7., 3.) });
    let grid = dvsgi::render::voxel::VoxelGrid::for_scene(&s);
    let layer = (-1.5 - grid.origin.z) / grid.voxel_size;
    assert!((layer.fract() - 0.5).abs() < 0.1, "the wall at {layer} voxels");
    s
}

/// A mirror shows a wall lit only by bounced light in the colour of the wall's albedo: white
/// light reaches the wall (from a white floor under a white sun), and a Lambertian surface sends
/// back its albedo times what reaches it, so the reflection's G/R and B/R are the albedo's 0.5
/// and 0.25 (but for the little light the wall sends back to itself through the floor), with
/// either source of a hit's indirect light. Guards against the voxel light at a reflected hit
/// (`gi.rt_hit_indirect = "voxel"`: the light leaving the voxel, albedo included) multiplied by
/// the hit's albedo a second time, which shows the albedo squared: 0.25 and 0.0625.
#[test]
fn a_mirror_shows_a_wall_lit_by_bounced_light_in_the_colour_of_its_albedo() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    for hit in [HitIndirect::Voxel, HitIndirect::Cones] {
        let mut s = wall_lit_by_its_floor();
        s.settings.gi.rt_hit_indirect = hit;
        let (out, s) = render(&ctx, s);
        let (mut sum, mut n) = (Vec3::ZERO, 0);
        for y in 0..s.settings.height {
            for x in 0..s.settings.width {
                let (p, _, w) = reflection_at(&s, x, y);
                // Mirror pixels away from its edges whose reflection lands on the wall, a metre
                // or more above the floor (its voxels hold the wall alone).
                if p.x.abs() < 0.8 && p.z.abs() < 0.8 && w.x.abs() < 1.5 && (1.0..5.5).contains(&w.y) {
                    sum += Vec3::from(out.radiance_at(x, y));
                    n += 1;
                }
            }
        }
        let (g, b) = (sum.y / sum.x, sum.z / sum.x);
        println!("{hit:?} at hits: the wall in the mirror ({n} pixels) {}, G/R {g:.4}, B/R {b:.4}", sum / n as f32);
        assert!(n >= 20, "only {n} pixels see the wall in the mirror");
        assert!(sum.x / n as f32 > 0.01, "{hit:?}: the wall has bounced light: {}", sum / n as f32);
        assert!((g - 0.5).abs() < 0.03 && (b - 0.25).abs() < 0.02, "{hit:?}: G/R {g:.4}, B/R {b:.4}, not 0.5, 0.25");
    }
    assert_no_validation_messages(&ctx);
}

/// The mirror follows a light that moves while the view and the objects stand still: after
/// three frames under the sun that lights the wall head-on, the sun turns 60 degrees (the wall
/// then gets half its irradiance) and in that same frame the mirror shows the wall at its new
/// radiance, Ks (n+8)/(n+1) cos^2 of it within 2%. Guards against the reflections' history
/// restarting only when the camera or an object moves: averaged with the frames before the
/// turn, the mirror showed the wall at 1.75 times its radiance.
#[test]
fn the_mirror_follows_a_light_that_moves_while_the_view_stands_still() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let s = mirror_scene();
    assert!(s.settings.gi.specular_history > 4, "the reflections keep a history");
    let mut r = Renderer::new(&ctx, s.clone()).expect("renderer");
    for _ in 0..3 {
        r.render(0.0, false).expect("frame");
    }
    // wi = (0, sin 60, cos 60): the wall (normal +z) gets cos 60 of the irradiance.
    let direction = Vec3::new(0.0, -(0.75f32.sqrt()), -0.5);
    r.scene.lights[0].kind = LightKind::Directional { direction, irradiance: Vec3::splat(IRRADIANCE) };
    r.render(0.0, true).expect("frame after the turn");
    let out = r.output();
    drop(r);
    assert_reflects_the_wall(&s, &out, &out, 0.5 * WALL_ALBEDO * IRRADIANCE / PI);
    assert_no_validation_messages(&ctx);
}

/// A ceiling lamp's housing, as cornell-sphere's light quad: a white ceiling (y = 2, facing
/// down) and, a centimetre under it, an opaque square (half side 0.4, turned 30 degrees) with a
/// point light 3 cm under the ceiling below its centre. The square shades the ceiling out to
/// 1.5 times its own size; the camera looks straight up at it from 2 m below, 64 x 64.
fn lamp_housing() -> Scene {
    let v = Vec3::new;
    let (c, s30) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let (u, w) = (v(c, 0.0, s30) * 0.4, v(-s30, 0.0, c) * 0.4);
    let ceiling = quad(v(0.0, 2.0, 0.0), v(2.0, 0.0, 0.0), v(0.0, 0.0, 2.0), Vec3::NEG_Y);
    let housing = quad(v(0.0, 1.99, 0.0), u, w, Vec3::NEG_Y);
    let camera =
        Camera { position: Vec3::ZERO, target: v(0.0, 2.0, 0.0), up: Vec3::Z, fov_y_deg: 60.0, near: 0.05, far: 10.0 };
    let lamp = Light {
        name: "lamp".into(),
        kind: LightKind::Point { position: v(0.0, 1.97, 0.0), intensity: Vec3::ONE },
        cast_shadows: true,
        motion: Motion::None,
    };
    let white = |name: &str| Material::diffuse(name, Vec3::splat(WALL_ALBEDO));
    let mut s = scene_of(
        vec![mesh("ceiling", &ceiling, 0, None), mesh("housing", &housing, 1, None)],
        vec![white("ceiling"), white("housing")],
        camera,
        vec![lamp],
        Aabb { min: v(-2.5, -0.5, -2.5), max: v(2.5, 2.5, 2.5) },
    );
    (s.settings.width, s.settings.height) = (64, 64);
    (s.settings.gi.mode, s.settings.gi.shadows) = (GiMode::None, DirectShadows::Rt);
    s
}

/// Shadow rays shade the ceiling beside a lamp's housing as the path tracer does: the edge of
/// the shadow the housing casts on the ceiling (seen around it from below) lies within 3/4 of a
/// pixel of the path tracer's, on average along it (the pixels whose shadowing differs, over the
/// edge's length in pixels; a pixel is shadowed where its direct light is under half the
/// unshadowed ceiling's, albedo / pi I cos / d^2). The rays from there graze the housing's edge
/// from a centimetre under it, so where they start matters: a ray started d lower passes under
/// the edge 20 d further out. Guards against the rays started a tenth of the
/// pixel's footprint off the surface instead of a hundredth (cornell-sphere's ceiling relMSE
/// 6.8 against 2.0).
#[test]
fn shadow_rays_shade_the_ceiling_beside_a_lamps_housing_as_the_path_tracer_does() {
    let ctx = context();
    if !has_ray_queries(&ctx) {
        return;
    }
    let s = lamp_housing();
    let options = ReferenceOptions { spp: 1, max_bounces: Some(0), ..Default::default() };
    let mut pt = PathTracer::new(&ctx, &s, options).expect("path tracer");
    pt.run(|_, _| {}).expect("trace");
    let reference = pt.image().expect("read back").mean;
    drop(pt);
    let (out, s) = render(&ctx, s);
    let tris = triangles(&s, 0.0);
    let lamp = Vec3::new(0.0, 1.97, 0.0);
    let (mut shadowed, mut differ) = (0, 0);
    for y in 0..s.settings.height {
        for x in 0..s.settings.width {
            let (o, d) = camera_ray(&s, x, y);
            let Some((t, _)) = raycast(&tris, o, d, 1e-4, 1e4).filter(|&(_, k)| tris[k].material == 0) else {
                continue;
            };
            let to_lamp = lamp - (o + d * t);
            let lit = WALL_ALBEDO / PI * (-to_lamp.normalize().y).max(0.0) / to_lamp.length_squared();
            let i = (y * s.settings.width + x) as usize;
            let (pt_dark, rt_dark) = (reference[3 * i + 1] < 0.5 * lit, out.radiance[4 * i + 1] < 0.5 * lit);
            shadowed += usize::from(pt_dark);
            differ += usize::from(pt_dark != rt_dark);
        }
    }
    // The shadow's edge: a square of half side 0.4 * 3 / 2 (the housing seen from the lamp),
    // in pixels of the ceiling 2 m from the camera.
    let pixel = 2.0 * 2.0 * (30f32.to_radians()).tan() / s.settings.height as f32;
    let edge = 8.0 * 0.6 / pixel;
    println!(
        "the housing's shadow on the ceiling: {shadowed} pixels in the path tracer's, {differ} differ: its edge {:.2} \
         pixels off ({edge:.0} pixels long)",
        differ as f32 / edge
    );
    assert!(shadowed as f32 > 1.5 * edge, "only {shadowed} shadowed ceiling pixels in view");
    assert!(
        (differ as f32) < 0.75 * edge,
        "the shadow's edge is {:.2} pixels off the path tracer's",
        differ as f32 / edge
    );
    assert_no_validation_messages(&ctx);
}

//! How much indirect light the cone tracer puts where, against ground truth (lavapipe in CI,
//! validation on): the Cornell box region by region against a cached path-traced reference,
//! closed boxes against Le / (1 - rho), a lone plane against zero, the directional volumes
//! and the specular cone against geometry, and flat faces against stripes.

mod common;

use common::*;
use dvsgi::metrics::LinearImage;
use dvsgi::reference::{PathTracer, ReferenceOptions};
use dvsgi::regions::{region_stats, Grouping, Pair, RegionMap, RegionStats};
use dvsgi::render::{FrameOutput, Renderer};
use dvsgi::scene::{Aabb, Camera, Material, Motion, Relief, Scene};
use glam::Vec3;

/// The cached Cornell references: 64x64 at 4096 spp (full and direct light only), traced with
/// `dvsgi reference scenes/cornell-box.toml --width 64 --height 64 --spp 4096 --out
/// tests/data/cornell-64.exr` (and `--spp 64 --bounces 0` for the direct light).
fn data(name: &str) -> LinearImage {
    LinearImage::read_exr(&repo().join("tests/data").join(name)).unwrap()
}

const SIZE: &str = "64";

fn cornell(overrides: &[(&str, &str)]) -> Scene {
    let mut all = vec![("render.width", SIZE), ("render.height", SIZE), ("gi.voxel_resolution", "64")];
    all.extend_from_slice(overrides);
    load(&repo().join("scenes/cornell-box.toml"), &all)
}

fn linear(out: &FrameOutput) -> LinearImage {
    LinearImage { width: out.width, height: out.height, rgb: dvsgi::output::radiance_rgb(out) }
}

fn minus(a: &LinearImage, b: &LinearImage) -> LinearImage {
    LinearImage { width: a.width, height: a.height, rgb: a.rgb.iter().zip(&b.rgb).map(|(x, y)| x - y).collect() }
}

/// The path tracer's indirect light of `scene` (its full image minus its direct light), at
/// `spp` samples per pixel each.
fn path_traced_indirect(ctx: &std::sync::Arc<dvsgi::gpu::Context>, scene: &Scene, spp: u32) -> LinearImage {
    let trace = |max_bounces: Option<u32>| {
        let mut pt = PathTracer::new(ctx, scene, ReferenceOptions { spp, max_bounces, ..Default::default() }).unwrap();
        pt.run(|_, _| {}).unwrap();
        let img = pt.image().unwrap();
        LinearImage { width: img.width, height: img.height, rgb: img.mean }
    };
    minus(&trace(None), &trace(Some(0)))
}

fn stats<'a>(all: &'a [RegionStats], grouping: Grouping, name: &str) -> &'a RegionStats {
    all.iter().find(|s| s.grouping == grouping && s.name == name).unwrap_or_else(|| panic!("no region {name}"))
}

/// The cached reference still describes the scene: a fresh 64-spp trace agrees with it per
/// mesh within 4 standard errors of the fresh trace (plus 1%).
fn check_cached_reference(ctx: &std::sync::Arc<dvsgi::gpu::Context>, scene: &Scene, cached: &LinearImage) {
    let mut pt = PathTracer::new(ctx, scene, ReferenceOptions { spp: 64, ..Default::default() }).unwrap();
    pt.run(|_, _| {}).unwrap();
    let fresh = pt.image().unwrap();
    drop(pt);
    let fresh_img = LinearImage { width: fresh.width, height: fresh.height, rgb: fresh.mean.clone() };
    let var = LinearImage { width: fresh.width, height: fresh.height, rgb: fresh.variance.clone() };
    let map = RegionMap::trace(scene, fresh.width, fresh.height);
    let pair = Pair { test: cached, reference: &fresh_img, reference_variance: Some(&var) };
    for s in region_stats(&map, &pair).iter().filter(|s| s.grouping == Grouping::Mesh) {
        let tolerance = 4.0 * s.ratio_noise.unwrap() + 0.01;
        assert!(
            (s.ratio - 1.0).abs() < tolerance,
            "tests/data/cornell-64.exr is stale for {}: cached / fresh = {:.4} (noise {:.4}); re-trace it",
            s.name,
            s.ratio,
            s.ratio_noise.unwrap()
        );
    }
}

/// Cornell box at the defaults (64x64 pixels, 64^3 voxels): the indirect light of every wall,
/// the floor, the ceiling and each block's sides against the reference's (reference minus its
/// direct light). At 128^3 and 128x128 every region is within 0.80..1.25 (ACCURACY.md); 64^3
/// voxels are coarser, so the bounds here are 0.65..1.40, and the whole image within 10%.
#[test]
fn cornell_indirect_light_matches_the_reference_region_by_region() {
    let ctx = context();
    let scene = cornell(&[]);
    let reference = data("cornell-64.exr");
    check_cached_reference(&ctx, &scene, &reference);
    let direct = data("cornell-64-direct.exr");
    let (out, scene) = render(&ctx, scene);
    let (indirect, _) = render(&ctx, cornell(&[("render.view", "\"indirect\"")]));
    let map = RegionMap::trace(&scene, 64, 64);
    let truth = minus(&reference, &direct);
    let ind = region_stats(&map, &Pair { test: &linear(&indirect), reference: &truth, reference_variance: None });
    let whole = region_stats(&map, &Pair { test: &linear(&out), reference: &reference, reference_variance: None });
    let mut report = String::new();
    for s in ind.iter().filter(|s| s.grouping == Grouping::Surface && !s.small) {
        report += &format!("{} {:.3} ({} px); ", s.name, s.ratio, s.pixels);
    }
    eprintln!("indirect ratio by surface: {report}");
    eprintln!("indirect energy {:.3}, image energy {:.3}", ind[0].ratio, whole[0].ratio);
    for name in
        ["ceiling -y", "floor +y", "backWall -z", "leftWall -x", "rightWall +x", "tallBlock -z", "shortBlock -z"]
    {
        let s = stats(&ind, Grouping::Surface, &format!("box/{name}"));
        assert!((0.65..=1.40).contains(&s.ratio), "indirect light on {name}: {:.3} of the reference's", s.ratio);
    }
    assert!((0.90..=1.20).contains(&ind[0].ratio), "indirect energy {:.3}", ind[0].ratio);
    assert!((0.95..=1.10).contains(&whole[0].ratio), "image energy {:.3}", whole[0].ratio);
    // Colour: the red wall's indirect light is as red as the reference's (self-lighting made
    // coloured walls see their own colour).
    let red = stats(&ind, Grouping::Surface, "box/leftWall -x");
    let share = |rgb: [f64; 3]| rgb[0] / (rgb[0] + rgb[1] + rgb[2]);
    let (got, want) = (share(red.test_rgb), share(red.reference_rgb));
    assert!((got - want).abs() < 0.05, "red share of the red wall's indirect light {got:.3} vs {want:.3}");
}

/// Occlusion is counted once: by default the cone AO does not darken the image. An open
/// corner (a floor meeting a wall, lit from the open side) gets at least most of the indirect
/// light the path tracer finds near the seam, while `gi.ao = true` (AO multiplying the
/// traced light, as many engines do) takes away a large part of it.
#[test]
fn an_open_corner_is_not_darkened_by_ambient_occlusion() {
    let ctx = context();
    let floor = quad(Vec3::new(0.5, 0.0, 0.5), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), Vec3::Y);
    let wall = quad(Vec3::new(0.0, 0.5, 0.5), Vec3::new(0.0, 0.5, 0.0), Vec3::new(0.0, 0.0, 0.5), Vec3::X);
    let make = |ao: bool, view: dvsgi::scene::View| {
        let mut s = scene_of(
            vec![mesh("floor", &floor, 0, None), mesh("wall", &wall, 0, None)],
            vec![material("white", 0.8, Vec3::ZERO)],
            camera(Vec3::new(1.1, 0.6, 0.5), Vec3::new(0.0, 0.0, 0.5), 60.0),
            vec![point_light(Vec3::new(0.7, 0.8, 0.5), 1.0)],
            Aabb { min: Vec3::splat(-0.05), max: Vec3::splat(1.05) },
        );
        s.settings.gi.ao = ao;
        s.settings.view = view;
        s
    };
    let scene = make(false, dvsgi::scene::View::Final);
    let truth = path_traced_indirect(&ctx, &scene, 512).rgb;
    let (default, _) = render(&ctx, make(false, dvsgi::scene::View::Indirect));
    let (with_ao, _) = render(&ctx, make(true, dvsgi::scene::View::Indirect));
    // Pixels within 5 cm of the seam (on either surface).
    let tris = triangles(&scene, 0.0);
    let near_seam: Vec<usize> = (0..32 * 32)
        .filter(|&i| {
            let (o, d) = camera_ray(&scene, (i % 32) as u32, (i / 32) as u32);
            raycast(&tris, o, d, 1e-4, 1e4)
                .map(|(t, _)| o + d * t)
                .is_some_and(|p| p.x.max(p.y) < 0.05 && p.z > 0.1 && p.z < 0.9)
        })
        .collect();
    assert!(near_seam.len() >= 20, "{} pixels near the seam", near_seam.len());
    let sum = |v: &[f32], stride: usize| {
        near_seam.iter().map(|&i| (0..3).map(|c| v[stride * i + c] as f64).sum::<f64>()).sum::<f64>()
    };
    let want = sum(&truth, 3);
    let (got, got_ao) = (sum(&default.radiance, 4) / want, sum(&with_ao.radiance, 4) / want);
    eprintln!("indirect light near the seam: {got:.3} of the reference's; with gi.ao = true {got_ao:.3}");
    // Not darkened. It is too bright instead (1.9 here with 16 cones, 2.0 with 9; 1.3-1.4
    // away from the seam): cones whose footprint grazes a lit surface see it as opaque
    // (ACCURACY.md, "What the tracer cannot do"); the upper bound only catches gross errors.
    assert!((0.75..=2.5).contains(&got), "near the seam the indirect light is {got:.3} of the reference's");
    assert!(got_ao < 0.5 * got, "AO should darken the seam when asked for: {got_ao:.3} vs {got:.3}");
}

/// Flat faces show no stripes: on the tall block's front face (not aligned with the voxel
/// grid, so it voxelizes as a staircase) the column-to-column variation of the indirect light
/// is no larger than the reference's (its noise plus its real gradient), with 25% margin.
#[test]
fn flat_faces_have_no_stripes() {
    let ctx = context();
    let reference = data("cornell-64.exr");
    let direct = data("cornell-64-direct.exr");
    let truth = minus(&reference, &direct);
    let (ind, scene) = render(&ctx, cornell(&[("render.view", "\"indirect\"")]));
    let map = RegionMap::trace(&scene, 64, 64);
    let face = map.surfaces.iter().position(|s| s.mesh == "tallBlock" && s.facing == "-z").unwrap() as u32;
    let variation = |img: &LinearImage| {
        // Mean over the face's rows of |second difference| of luminance along each row,
        // relative to the face's mean (an interior pixel needs both neighbours on the face).
        let lum = |i: usize| (img.rgb[3 * i] + img.rgb[3 * i + 1] + img.rgb[3 * i + 2]) as f64;
        let (mut sum, mut mean, mut n) = (0.0, 0.0, 0usize);
        for y in 0..64usize {
            for x in 1..63usize {
                let i = y * 64 + x;
                if map.pixel[i - 1] == face && map.pixel[i] == face && map.pixel[i + 1] == face {
                    sum += (lum(i - 1) - 2.0 * lum(i) + lum(i + 1)).abs();
                    mean += lum(i);
                    n += 1;
                }
            }
        }
        assert!(n > 100, "{n} face pixels");
        sum / mean
    };
    let (got, want) = (variation(&linear(&ind)), variation(&truth));
    eprintln!("column-to-column variation on the tall block's face: {got:.4} (reference {want:.4})");
    assert!(got <= 1.25 * want, "stripes: variation {got:.4} vs the reference's {want:.4}");
}

fn material(name: &str, albedo: f32, emission: Vec3) -> Material {
    Material { emission, ..Material::diffuse(name, Vec3::splat(albedo)) }
}

/// The inside of a cube of side 1 around the origin, normals inward.
fn closed_box() -> Vec<[Vec3; 3]> {
    let mut tris = Vec::new();
    for axis in 0..3 {
        for s in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = -s;
            let mut u = Vec3::ZERO;
            u[(axis + 1) % 3] = 0.5;
            let mut v = Vec3::ZERO;
            v[(axis + 2) % 3] = 0.5;
            tris.extend(quad(-n * 0.5, u, v, n));
        }
    }
    tris
}

/// A camera at `position` looking at `target` (y up) with a vertical field of view in degrees.
fn camera(position: Vec3, target: Vec3, fov_y_deg: f32) -> Camera {
    Camera { position, target, up: Vec3::Y, fov_y_deg, near: 0.01, far: 10.0 }
}

fn inside_camera() -> Camera {
    Camera {
        position: Vec3::new(0.1, -0.05, 0.2),
        target: Vec3::new(-0.3, 0.1, -0.4),
        up: Vec3::Y,
        fov_y_deg: 100.0,
        near: 0.001,
        far: 10.0,
    }
}

/// The closed box of emission `le` and albedo `rho`, seen from inside (the furnace).
fn furnace(rho: f32, le: f32) -> Scene {
    scene_of(
        vec![mesh("box", &closed_box(), 0, None)],
        vec![material("furnace", rho, Vec3::splat(le))],
        inside_camera(),
        vec![],
        Aabb { min: Vec3::splat(-0.55), max: Vec3::splat(0.55) },
    )
}

/// A closed box of emission Le and albedo rho radiates Le / (1 - rho) everywhere once the
/// bounces have converged (the furnace), here through the cones alone; the diagnostic ray
/// gather through the voxels gets the one-bounce value rho Le.
#[test]
fn closed_emissive_box_reaches_le_over_one_minus_rho() {
    let ctx = context();
    let (rho, le) = (0.5f32, 1.0f32);
    let make = |extra: &dyn Fn(&mut Scene)| {
        let mut s = furnace(rho, le);
        extra(&mut s);
        s
    };
    let mean_and_min = |out: &FrameOutput| {
        let v: Vec<f32> = out.radiance.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) / 3.0).collect();
        (v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64, v.iter().cloned().fold(f32::MAX, f32::min))
    };
    // Several frames: each update feeds its bounced light to the next.
    let mut r = Renderer::new(&ctx, make(&|s| s.settings.gi.bounces = 2)).unwrap();
    for _ in 0..4 {
        r.render(0.0, false).unwrap();
    }
    r.render(0.0, true).unwrap();
    let (mean, min) = mean_and_min(&r.output());
    drop(r);
    let want = (le / (1.0 - rho)) as f64;
    eprintln!("furnace through the cones: mean {mean:.4}, min {min:.4}, expected {want}");
    assert!((mean / want - 1.0).abs() < 0.05, "mean {mean:.4} vs Le/(1-rho) = {want}");
    assert!(min as f64 > 0.9 * want, "darkest pixel {min:.4} vs {want}");
    // One bounce gathered by cones and by rays: rho Le (emission is stored in 8 bits).
    for (label, rays) in [("cones", 0), ("rays", 16)] {
        let (out, _) = render(
            &ctx,
            make(&|s| {
                s.settings.gi.bounces = 0;
                s.settings.gi.diffuse_rays = rays;
                s.settings.view = dvsgi::scene::View::Indirect;
            }),
        );
        let (mean, _) = mean_and_min(&out);
        eprintln!("one bounce by {label}: {mean:.4} (rho Le = {})", rho * le);
        let tolerance = if rays > 0 { 0.015 } else { 0.06 };
        assert!((mean / (rho * le) as f64 - 1.0).abs() < tolerance, "{label}: {mean:.4} vs {}", rho * le);
    }
    assert_no_validation_messages(&ctx);
}

/// `gi.voxel_cover = "area"` (glsl/include/voxel.glsl): a voxel is as opaque as the share of
/// its cross-section its surfaces cover, and a surface stays opaque along every column of
/// voxels it crosses along its dominant axis. A closed emissive box turned obliquely to the
/// grid (30 degrees about y, then 20 about x, so every wall cuts voxels in part along a
/// staircase) stays closed to rays through the voxels: they return rho Le per bounce, as with
/// the conservative "touch" cover. Cones see the walls through the directional mips, which
/// composite along every axis, and along an axis that is not a wall's dominant one its
/// partial voxels let some light out: 0.462 of Le against 0.485 with "touch" (32^3, lavapipe;
/// ACCURACY.md, "Thin surfaces and narrow openings"). With "directional" each axis sees a
/// wall's voxels as much opaque as the wall's projected area across it, which for an oblique
/// wall's staircase of partial voxels lets out more (0.44). The bounds say so.
#[test]
fn area_cover_keeps_an_oblique_closed_box_closed() {
    let ctx = context();
    let (rho, le) = (0.5f32, 1.0f32);
    let turn = glam::Quat::from_rotation_x(20f32.to_radians()) * glam::Quat::from_rotation_y(30f32.to_radians());
    let tris: Vec<[Vec3; 3]> = closed_box().iter().map(|t| t.map(|p| turn * p)).collect();
    let one_bounce = |cover: dvsgi::scene::VoxelCover, rays: u32| {
        let mut s = scene_of(
            vec![mesh("box", &tris, 0, None)],
            vec![material("furnace", rho, Vec3::splat(le))],
            inside_camera(),
            vec![],
            Aabb { min: Vec3::splat(-0.8), max: Vec3::splat(0.8) },
        );
        s.settings.gi.voxel_resolution = 32;
        s.settings.gi.bounces = 0;
        s.settings.gi.diffuse_rays = rays;
        s.settings.gi.voxel_cover = cover;
        s.settings.view = dvsgi::scene::View::Indirect;
        let (out, _) = render(&ctx, s);
        out.radiance.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).sum::<f64>()
            / (out.radiance.len() / 4) as f64
    };
    // (rays or cones, how far touch, area and directional may be from rho Le)
    for (label, rays, tolerance) in [("rays", 16, [0.02, 0.02, 0.02]), ("cones", 0, [0.06, 0.1, 0.15])] {
        let touch = one_bounce(dvsgi::scene::VoxelCover::Touch, rays);
        let area = one_bounce(dvsgi::scene::VoxelCover::Area, rays);
        let directional = one_bounce(dvsgi::scene::VoxelCover::Directional, rays);
        eprintln!(
            "oblique closed box, one bounce by {label}: touch {touch:.4}, area {area:.4}, directional {directional:.4} \
             (rho Le = {})",
            rho * le
        );
        let covers =
            [("touch", touch, tolerance[0]), ("area", area, tolerance[1]), ("directional", directional, tolerance[2])];
        for (cover, mean, tol) in covers {
            assert!((mean / (rho * le) as f64 - 1.0).abs() < tol, "{label}, {cover}: {mean:.4} vs {}", rho * le);
        }
    }
    assert_no_validation_messages(&ctx);
}

/// `gi.voxel_cover = "directional"` (glsl/include/voxel.glsl, `directional_share`): a voxel is
/// as opaque along each axis as its surfaces' projected area across that axis, so an emissive
/// plate seen edge-on is a thin line, as it is, not a voxel-thick glowing slab. A wall facing
/// the plate's edge, in its plane, gets almost no light from it (the path tracer's answer):
/// with "touch" its middle rows get 30 times the path tracer's light from the slab's side,
/// with "directional" a third of that (what is left comes through the other axes' volumes
/// of coarse texels: ACCURACY.md). Face on, the plate keeps its light.
#[test]
fn directional_cover_shows_a_plate_seen_edge_on_as_thin() {
    let ctx = context();
    let c = Vec3::splat(0.5);
    // The plate lies inside one layer of voxels at 32^3 (y 0.5..0.53), 0.25..0.65 m from the wall.
    let plate = quad(Vec3::new(0.3, 0.515, 0.5), Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.3), Vec3::Y);
    let edge_wall = quad(Vec3::new(0.95, 0.5, 0.5), Vec3::new(0.0, 0.45, 0.0), Vec3::new(0.0, 0.0, 0.45), -Vec3::X);
    let face_wall = quad(Vec3::new(0.3, 0.95, 0.5), Vec3::new(0.45, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.45), -Vec3::Y);
    // (which wall, its camera, the rows of the picture measured)
    let setups = [
        ("edge on", edge_wall, camera(c, Vec3::new(1.0, 0.5, 0.5), 40.0), 14..18),
        (
            "face on",
            face_wall,
            Camera { up: Vec3::Z, ..camera(Vec3::new(0.3, 0.6, 0.5), Vec3::new(0.3, 1.0, 0.5), 40.0) },
            8..24,
        ),
    ];
    for (label, wall, camera, rows) in setups {
        let scene = move |cover: dvsgi::scene::VoxelCover| {
            let mut s = scene_of(
                vec![mesh("plate", &plate, 0, None), mesh("wall", &wall, 1, None)],
                vec![material("emitter", 0.0, Vec3::ONE), material("white", 0.8, Vec3::ZERO)],
                camera.clone(),
                vec![],
                Aabb { min: Vec3::ZERO, max: Vec3::ONE },
            );
            s.settings.gi.voxel_resolution = 32;
            s.settings.gi.bounces = 0;
            s.settings.gi.voxel_cover = cover;
            s
        };
        let band = move |rgb: &[f32], width: usize| {
            let (mut sum, mut n) = (0.0f64, 0usize);
            for (i, p) in rgb.chunks_exact(3).enumerate() {
                if rows.contains(&(i / width)) && (8..24).contains(&(i % width)) {
                    sum += f64::from(p[0] + p[1] + p[2]) / 3.0;
                    n += 1;
                }
            }
            sum / n as f64
        };
        let truth = band(&path_traced_indirect(&ctx, &scene(dvsgi::scene::VoxelCover::Touch), 256).rgb, 32);
        let cones = |cover: dvsgi::scene::VoxelCover| {
            let mut s = scene(cover);
            s.settings.view = dvsgi::scene::View::Indirect;
            let (out, _) = render(&ctx, s);
            band(&linear(&out).rgb, 32)
        };
        let (touch, directional) =
            (cones(dvsgi::scene::VoxelCover::Touch), cones(dvsgi::scene::VoxelCover::Directional));
        eprintln!("{label}: indirect {truth:.5} (path tracer), {touch:.5} (touch), {directional:.5} (directional)");
        if label == "edge on" {
            // 0.0029, 0.086 and 0.026 (lavapipe)
            assert!(directional < 0.5 * touch, "edge on: directional {directional:.5}, touch {touch:.5}");
            assert!(directional - truth < 0.5 * (touch - truth), "edge on: {directional:.5} vs {truth:.5}");
        } else {
            // 0.222, 0.313 and 0.299: both keep the light a footprint's partial cover overstates.
            assert!((directional / touch - 1.0).abs() < 0.1, "face on: directional {directional:.5}, touch {touch:.5}");
        }
    }
    assert_no_validation_messages(&ctx);
}

/// The closed emissive box (rho 0.5, Le 1) seen through the cones alone, set up by `setup`:
/// the mean of its indirect view, one bounce of rho Le when the walls stay opaque.
fn furnace_one_bounce(ctx: &std::sync::Arc<dvsgi::gpu::Context>, setup: impl FnOnce(&mut Scene)) -> f64 {
    let mut furnace = furnace(0.5, 1.0);
    furnace.settings.gi.bounces = 0;
    furnace.settings.view = dvsgi::scene::View::Indirect;
    setup(&mut furnace);
    let (out, _) = render(ctx, furnace);
    out.radiance.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).sum::<f64>()
        / (out.radiance.len() / 4) as f64
}

/// The Cornell box's indirect light (64x64, 64^3) with `settings` (key, value), against the
/// cached reference's, by region.
fn cornell_indirect_with(ctx: &std::sync::Arc<dvsgi::gpu::Context>, settings: &[(&str, &str)]) -> Vec<RegionStats> {
    let truth = minus(&data("cornell-64.exr"), &data("cornell-64-direct.exr"));
    let (out, scene) = render(ctx, cornell(&[&[("render.view", "\"indirect\"")], settings].concat()));
    let map = RegionMap::trace(&scene, 64, 64);
    region_stats(&map, &Pair { test: &linear(&out), reference: &truth, reference_variance: None })
}

/// `gi.cone_filter = "two-tap"` (opacity filtered across each cone, optical depth along it):
/// walls stay opaque (the closed emissive box still returns rho Le per bounce through the
/// cones, as with trilinear samples), and a surface that covers part of a footprint no
/// longer occludes all of it, so the Cornell box's walls, too bright with trilinear samples
/// (ACCURACY.md), lose part of their excess, and the whole image's indirect light with them.
#[test]
fn two_tap_cone_samples_keep_walls_opaque_and_partial_cover_partial() {
    let ctx = context();
    let rho_le = 0.5;
    let mean = furnace_one_bounce(&ctx, |s| s.settings.gi.cone_filter = dvsgi::scene::ConeFilter::TwoTap);
    eprintln!("one bounce by two-tap cones in the closed box: {mean:.4} (rho Le = {rho_le})");
    assert!((mean / rho_le - 1.0).abs() < 0.06, "two-tap: {mean:.4} vs {rho_le}");

    let indirect = |filter: &str| cornell_indirect_with(&ctx, &[("gi.cone_filter", filter)]);
    let (trilinear, two_tap) = (indirect("\"trilinear\""), indirect("\"two-tap\""));
    for name in ["backWall -z", "leftWall -x", "rightWall +x"] {
        let region = format!("box/{name}");
        let (a, b) =
            (stats(&trilinear, Grouping::Surface, &region).ratio, stats(&two_tap, Grouping::Surface, &region).ratio);
        eprintln!("{name}: indirect {a:.3} of the reference's with trilinear samples, {b:.3} with two taps");
        assert!(a > 1.0 && b < a - 0.03 && b > 0.9, "{name}: trilinear {a:.3}, two-tap {b:.3}");
    }
    let (a, b) = (trilinear[0].ratio, two_tap[0].ratio);
    eprintln!("indirect energy: trilinear {a:.3}, two-tap {b:.3}");
    assert!((b - 1.0).abs() < (a - 1.0).abs(), "indirect energy: trilinear {a:.3}, two-tap {b:.3}");
}

/// `gi.footprint = "quadrants"`: each quarter of a cone's footprint composites its own
/// transmittance. Walls stay opaque (the closed emissive box still returns rho Le per bounce),
/// and a wall beside a cone's axis blocks the quarters it covers once instead of a little more
/// of the whole footprint at every sample, so the Cornell box's walls and ceiling, too bright
/// with one transmittance per cone (ACCURACY.md), lose most of their excess: part by the
/// pixels' cones (`gi.footprint`), part by the bounce's (`gi.bounce_footprint`).
#[test]
fn quadrant_footprints_keep_walls_opaque_and_count_a_wall_beside_the_cone_once() {
    let ctx = context();
    let rho_le = 0.5;
    let mean = furnace_one_bounce(&ctx, |s| s.settings.gi.footprint = dvsgi::scene::Footprint::Quadrants);
    eprintln!("one bounce by quadrant cones in the closed box: {mean:.4} (rho Le = {rho_le})");
    assert!((mean / rho_le - 1.0).abs() < 0.06, "quadrants: {mean:.4} vs {rho_le}");

    // gi.footprint sets the pixels' cones, gi.bounce_footprint the voxel bounce's.
    let indirect = |pixels: &str, bounce: &str| {
        cornell_indirect_with(&ctx, &[("gi.footprint", pixels), ("gi.bounce_footprint", bounce)])
    };
    let (q, w) = ("\"quadrants\"", "\"whole\"");
    let (whole, pixels, both) = (indirect(w, w), indirect(q, w), indirect(q, q));
    for name in ["ceiling -y", "backWall -z", "leftWall -x", "rightWall +x"] {
        let region = format!("box/{name}");
        let ratio = |r: &[RegionStats]| stats(r, Grouping::Surface, &region).ratio;
        let (a, p, b) = (ratio(&whole), ratio(&pixels), ratio(&both));
        eprintln!(
            "{name}: indirect {a:.3} of the reference's with whole footprints, {p:.3} with the pixels' \
             quadrants, {b:.3} with the bounce's too"
        );
        assert!(a > 1.0 && b < a - 0.03 && b > 0.9, "{name}: whole {a:.3}, quadrants {b:.3}");
        // Each cone set's quarters take their own share of the excess (64x64, 64^3, lavapipe: the
        // pixels' 0.03-0.07, the bounce's 0.035-0.04 more).
        assert!(p < a - 0.02 && b < p - 0.02, "{name}: whole {a:.3}, pixels' quadrants {p:.3}, both {b:.3}");
    }
}

/// A shadow-casting sun of irradiance 3 travelling along `direction`.
/// `gi.footprint = "shares"`: each quarter of a cone's footprint keeps the largest share of it
/// that it has met covered, and the whole footprint composites only the cover beyond the
/// quarters' along the path. Walls stay opaque (the closed emissive box still returns rho Le
/// per bounce), and a wall beside a cone is counted once, so the Cornell box's walls, too bright
/// with one transmittance per cone (ACCURACY.md), lose part of their excess, and the whole
/// image's indirect light comes nearer the reference's.
#[test]
fn quarter_shares_keep_walls_opaque_and_count_a_wall_beside_the_cone_once() {
    let ctx = context();
    let rho_le = 0.5;
    let mean = furnace_one_bounce(&ctx, |s| s.settings.gi.footprint = dvsgi::scene::Footprint::Shares);
    eprintln!("one bounce by cones with quarters' shares in the closed box: {mean:.4} (rho Le = {rho_le})");
    assert!((mean / rho_le - 1.0).abs() < 0.06, "shares: {mean:.4} vs {rho_le}");

    let indirect = |footprint: &str| cornell_indirect_with(&ctx, &[("gi.footprint", footprint)]);
    let (whole, shares) = (indirect("\"whole\""), indirect("\"shares\""));
    for name in ["backWall -z", "leftWall -x", "rightWall +x"] {
        let region = format!("box/{name}");
        let ratio = |r: &[RegionStats]| stats(r, Grouping::Surface, &region).ratio;
        let (a, b) = (ratio(&whole), ratio(&shares));
        eprintln!("{name}: indirect {a:.3} of the reference's with whole footprints, {b:.3} with shares");
        // 64x64, 64^3, lavapipe: the walls lose 0.022-0.046 of their excess.
        assert!(a > 1.0 && b < a - 0.015 && b > 0.9, "{name}: whole {a:.3}, shares {b:.3}");
    }
    let (a, b) = (whole[0].ratio, shares[0].ratio);
    eprintln!("indirect energy: whole {a:.3}, shares {b:.3}");
    // 1.146 -> 1.129 there.
    assert!((b - 1.0).abs() < (a - 1.0).abs() - 0.01, "indirect energy: whole {a:.3}, shares {b:.3}");
}

fn sun(direction: Vec3) -> dvsgi::scene::Light {
    dvsgi::scene::Light {
        name: "sun".into(),
        kind: dvsgi::scene::LightKind::Directional { direction: direction.normalize(), irradiance: Vec3::splat(3.0) },
        cast_shadows: true,
        motion: Motion::None,
    }
}

/// The voxel light reads the shadow maps on the surface inside each voxel (voxel.glsl,
/// SUM_OFFSET), as the pixels on that surface do: a wall under a 6 cm ledge, lit by a sun 13
/// degrees off the wall's plane (the ledge shadows 25 cm of it), has voxels as dark as its
/// pixels there. The wall lies 0.07 voxels into its voxels (3.75 cm): read half a voxel off
/// their centres, 3.5 cm off the wall, the point saw past the ledge's edge along the upper
/// 15 cm of the shadow.
#[test]
fn the_voxel_light_is_shadowed_where_its_surface_is() {
    let ctx = context();
    let wall = quad(Vec3::new(0.0, 0.5, 0.5), Vec3::new(0.0, 0.5, 0.0), Vec3::new(0.0, 0.0, 0.3), Vec3::X);
    let ledge = quad(Vec3::new(0.03, 0.8, 0.5), Vec3::new(0.03, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.3), -Vec3::Y);
    let sun = sun(Vec3::new(-0.23, -0.97, 0.0));
    let make = |view: dvsgi::scene::View, mode: dvsgi::scene::GiMode| {
        let mut s = scene_of(
            vec![mesh("wall", &wall, 0, None), mesh("ledge", &ledge, 0, None)],
            vec![material("white", 0.8, Vec3::ZERO)],
            camera(Vec3::new(1.2, 0.5, 0.5), Vec3::new(0.0, 0.5, 0.5), 60.0),
            vec![sun.clone()],
            Aabb { min: Vec3::splat(-0.0775), max: Vec3::splat(1.1225) },
        );
        s.settings.width = 64;
        s.settings.height = 64;
        s.settings.view = view;
        s.settings.gi.mode = mode;
        s
    };
    let scene = make(dvsgi::scene::View::Final, dvsgi::scene::GiMode::None);
    let tris = triangles(&scene, 0.0);
    // Pixels showing the wall within 0.35..0.45 (lit) and 0.58..0.68 (in the ledge's shadow,
    // which ends at 0.547).
    let on_wall = |i: usize, lo: f32, hi: f32| {
        let (o, d) = camera_ray(&scene, (i % 64) as u32, (i / 64) as u32);
        raycast(&tris, o, d, 1e-4, 1e4)
            .map(|(t, _)| o + d * t)
            .is_some_and(|p| p.x.abs() < 1e-3 && p.y > lo && p.y < hi && (p.z - 0.5).abs() < 0.2)
    };
    let (direct, _) = render(&ctx, scene.clone());
    let (voxels, _) = render(&ctx, make(dvsgi::scene::View::VoxelRadiance, dvsgi::scene::GiMode::Vct));
    let mean = |out: &FrameOutput, lo: f32, hi: f32| {
        let (sum, n) = sum_where(out, |i| on_wall(i, lo, hi));
        assert!(n >= 40, "{n} pixels on the wall in {lo}..{hi}");
        (sum.x + sum.y + sum.z) / n as f32
    };
    let (pixels_lit, pixels_shadow) = (mean(&direct, 0.35, 0.45), mean(&direct, 0.58, 0.68));
    let (voxels_lit, voxels_shadow) = (mean(&voxels, 0.35, 0.45), mean(&voxels, 0.58, 0.68));
    eprintln!(
        "shadowed / lit under the ledge: pixels {:.3}, voxels {:.3}",
        pixels_shadow / pixels_lit,
        voxels_shadow / voxels_lit
    );
    assert!(pixels_shadow < 0.05 * pixels_lit, "the ledge shadows the pixels: {pixels_shadow} vs {pixels_lit}");
    assert!(voxels_shadow < 0.1 * voxels_lit, "the ledge shadows the voxels: {voxels_shadow} vs {voxels_lit}");
}

/// A lone lit plane receives (almost) no indirect light: its cones, and the diagnostic rays of
/// `gi.diffuse_rays`, must not see its own voxels, at any voxel resolution.
#[test]
fn a_lone_lit_plane_gets_no_indirect_light() {
    let ctx = context();
    let tris = quad(Vec3::ZERO, Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), Vec3::Y);
    for (res, rays) in [(16u32, 0u32), (64, 0), (16, 16), (64, 16)] {
        let mut s = scene_of(
            vec![mesh("plane", &tris, 0, None)],
            vec![material("white", 0.8, Vec3::ZERO)],
            camera(Vec3::new(0.0, 1.0, 1.2), Vec3::ZERO, 50.0),
            vec![point_light(Vec3::new(0.1, 0.3, 0.0), 1.0)],
            Aabb { min: Vec3::splat(-0.6), max: Vec3::splat(0.6) },
        );
        s.settings.gi.voxel_resolution = res;
        s.settings.gi.diffuse_rays = rays;
        let (direct, _) = render(&ctx, s.clone());
        s.settings.view = dvsgi::scene::View::Indirect;
        let (indirect, _) = render(&ctx, s);
        let mean = |o: &FrameOutput| o.radiance.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>();
        let share = mean(&indirect) / mean(&direct);
        eprintln!("{res}^3, {rays} rays: indirect light {share:.5} of the image");
        assert!(share < 0.005, "{res}^3, {rays} rays: a lone plane lights itself: indirect {share:.5} of the image");
    }
    assert_no_validation_messages(&ctx);
}

/// The diagnostic rays (`gi.diffuse_rays`) start past the voxels of the surface they leave by a
/// margin for the depth buffer's error (glsl/gi_trace.comp, RAY_MARGIN). `scenes/leak/corner.toml`
/// puts its floor on a voxel boundary at 256^3 and reads depth with a near plane of 1 cm: with a
/// margin of 1e-3 voxels, rows of floor pixels started inside the floor's voxels and saw its own
/// sunlight, and the floor's indirect light at 256^3 was twice that at 128^3 (and the path
/// tracer's). Both grids must agree, as they do with the cones.
#[test]
fn rays_through_the_voxels_do_not_see_their_own_floor() {
    let ctx = context();
    let floor_light = |res: u32| {
        let mut s = load(&repo().join("scenes/leak/corner.toml"), &[]);
        s.settings.gi.voxel_resolution = res;
        s.settings.gi.bounces = 0;
        s.settings.gi.first_update_bounces = 0;
        s.settings.gi.diffuse_rays = 16;
        s.settings.view = dvsgi::scene::View::Indirect;
        let (out, s) = render(&ctx, s);
        // The floor fills the picture's bottom quarter.
        let w = s.settings.width as usize;
        let h = s.settings.height as usize;
        let (mean, n) = mean_where(&out, |i| i / w >= h * 3 / 4);
        assert!(n > 0);
        (mean.x + mean.y + mean.z) as f64 / 3.0
    };
    let (coarse, fine) = (floor_light(128), floor_light(256));
    eprintln!("the corner's floor, one bounce by rays: 128^3 {coarse:.5}, 256^3 {fine:.5}");
    assert!(coarse > 0.0, "the lit wall lights the floor");
    assert!((fine / coarse - 1.0).abs() < 0.1, "256^3 {fine:.5} against 128^3 {coarse:.5}");
    assert_no_validation_messages(&ctx);
}

fn point_light(position: Vec3, intensity: f32) -> dvsgi::scene::Light {
    dvsgi::scene::Light {
        name: "light".into(),
        kind: dvsgi::scene::LightKind::Point { position, intensity: Vec3::splat(intensity) },
        cast_shadows: true,
        motion: Motion::None,
    }
}

/// Mean radiance of the pixels `keep` selects, and their number.
fn mean_where(out: &FrameOutput, keep: impl Fn(usize) -> bool) -> (Vec3, usize) {
    let (s, n) = sum_where(out, keep);
    (s / n.max(1) as f32, n)
}

/// The directional volumes: a red and a blue emissive layer two voxels apart, seen by white
/// walls on either side. Where the cones are wide enough to see both layers in one texel,
/// the volume of the cones' own direction must show the nearer layer: the wall on the red side
/// gets red light, the wall on the blue side blue light.
#[test]
fn cones_see_the_nearer_of_two_layers_in_each_direction() {
    let ctx = context();
    let (u, v) = (Vec3::new(0.0, 0.4, 0.0), Vec3::new(0.0, 0.0, 0.4));
    let c = Vec3::new(0.0, 0.5, 0.5);
    // Voxels 16 and 18 of 32: one texel of directional level 1 and above holds both.
    let red_layer = quad(c + Vec3::X * 0.53, u, v, -Vec3::X);
    let blue_layer = quad(c + Vec3::X * 0.59, u, v, Vec3::X);
    let red_side = quad(c + Vec3::X * 0.05, u, v, Vec3::X);
    let blue_side = quad(c + Vec3::X * 0.95, u, v, -Vec3::X);
    let look = |from: f32, to: f32| camera(c + Vec3::X * from, c + Vec3::X * to, 90.0);
    let colours = |camera: Camera| {
        let mut s = scene_of(
            vec![
                mesh("red", &red_layer, 0, None),
                mesh("blue", &blue_layer, 1, None),
                mesh("walls", &[red_side[0], red_side[1], blue_side[0], blue_side[1]], 2, None),
            ],
            vec![
                material("red", 0.0, Vec3::new(1.0, 0.0, 0.0)),
                material("blue", 0.0, Vec3::new(0.0, 0.0, 1.0)),
                material("white", 0.8, Vec3::ZERO),
            ],
            camera,
            vec![],
            Aabb { min: Vec3::ZERO, max: Vec3::ONE },
        );
        s.settings.gi.bounces = 0;
        s.settings.view = dvsgi::scene::View::Indirect;
        let (out, _) = render(&ctx, s);
        // The middle of the picture: the wall the camera faces.
        mean_where(&out, |i| {
            let (x, y) = (i % 32, i / 32);
            (8..24).contains(&x) && (8..24).contains(&y)
        })
        .0
    };
    let on_red_side = colours(look(0.4, 0.0));
    let on_blue_side = colours(look(0.7, 1.0));
    eprintln!("wall on the red side {on_red_side}, on the blue side {on_blue_side}");
    assert!(on_red_side.x > 3.0 * on_red_side.z, "the wall on the red side sees {on_red_side}");
    assert!(on_blue_side.z > 3.0 * on_blue_side.x, "the wall on the blue side sees {on_blue_side}");
}

/// The specular cone follows the mirror direction: on a glossy floor under one emissive
/// patch, the pixels whose mirror ray hits the patch get far more specular light than those
/// whose mirror ray misses it (including the ones right under the patch).
#[test]
fn specular_light_comes_from_the_mirror_direction() {
    let ctx = context();
    let floor = quad(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0), Vec3::Y);
    let patch = quad(Vec3::new(0.4, 0.6, 0.0), Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.2), -Vec3::Y);
    let glossy = Material {
        name: "glossy".into(),
        albedo: Vec3::splat(0.1),
        albedo_texture: None,
        mask_texture: None,
        normal_texture: None,
        relief: Relief::default(),
        specular: Vec3::splat(0.8),
        shininess: 200.0,
        emission: Vec3::ZERO,
    };
    let view = camera(Vec3::new(-1.2, 0.5, 0.0), Vec3::new(0.1, 0.0, 0.0), 60.0);
    let indirect = |specular: bool| {
        let mut s = scene_of(
            vec![mesh("floor", &floor, 0, None), mesh("patch", &patch, 1, None)],
            vec![glossy.clone(), material("light", 0.0, Vec3::splat(4.0))],
            view.clone(),
            vec![],
            Aabb { min: Vec3::new(-1.05, -0.05, -1.05), max: Vec3::new(1.05, 2.05, 1.05) },
        );
        s.settings.gi.bounces = 0;
        s.settings.gi.specular =
            if specular { dvsgi::scene::SpecularSource::Cone } else { dvsgi::scene::SpecularSource::Off };
        s.settings.view = dvsgi::scene::View::Indirect;
        render(&ctx, s)
    };
    let (with, scene) = indirect(true);
    let (without, _) = indirect(false);
    let tris = triangles(&scene, 0.0);
    let patch_tris: Vec<Triangle> = patch.iter().map(|t| Triangle { a: t[0], b: t[1], c: t[2], material: 1 }).collect();
    // Floor pixels, split by where their mirror ray goes.
    let mut hit = vec![false; 32 * 32];
    let mut floor_px = vec![false; 32 * 32];
    for y in 0..32u32 {
        for x in 0..32u32 {
            let (o, d) = camera_ray(&scene, x, y);
            if let Some((t, i)) = raycast(&tris, o, d, 1e-4, 1e4) {
                if tris[i].material == 0 {
                    let i = (y * 32 + x) as usize;
                    floor_px[i] = true;
                    let r = Vec3::new(d.x, -d.y, d.z);
                    hit[i] = raycast(&patch_tris, o + d * t, r, 1e-4, 1e4).is_some();
                }
            }
        }
    }
    let specular = |keep: &dyn Fn(usize) -> bool| {
        let (a, n) = mean_where(&with, keep);
        let (b, _) = mean_where(&without, keep);
        ((a - b).element_sum() / 3.0, n)
    };
    let (s_hit, n_hit) = specular(&|i| floor_px[i] && hit[i]);
    let (s_miss, n_miss) = specular(&|i| floor_px[i] && !hit[i]);
    eprintln!("specular light: mirror ray on the patch {s_hit:.4} ({n_hit} px), elsewhere {s_miss:.4} ({n_miss} px)");
    assert!(n_hit >= 10 && n_miss >= 100, "{n_hit} pixels reflect the patch, {n_miss} do not");
    assert!(
        s_hit > 5.0 * s_miss.max(0.0) && s_hit > 0.0,
        "specular {s_hit:.4} where the mirror ray hits vs {s_miss:.4}"
    );
}

/// McGuire's glossy Cornell box (a glossy sphere and box, an emissive ceiling light) at the
/// defaults, 64x64 and 64^3 voxels, against its cached reference (`dvsgi reference
/// scenes/cornell-glossy.toml --width 64 --height 64 --spp 4096`): the whole image within
/// 0.88..1.08 of the reference's energy and every mesh within 0.6..1.65 (measured: 0.86 for the
/// floor and the ceiling .. 1.61 for the glossy box); without the specular cone the glossy
/// objects lose most of their reflected light. The bound was 1.6 while one frame held 4
/// bounces: the glossy box got 1.57 from it, and 1.60 after 8 frames; with the first update's
/// bounce tail one frame holds the converged light, 1.61, as 16 bounces do (ACCURACY.md, "The
/// first update's bounce tail").
#[test]
fn glossy_cornell_box_agrees_with_the_reference() {
    let ctx = context();
    let glossy = |specular: &str| {
        load(
            &repo().join("scenes/cornell-glossy.toml"),
            &[
                ("render.width", SIZE),
                ("render.height", SIZE),
                ("gi.voxel_resolution", "64"),
                ("gi.specular", specular),
            ],
        )
    };
    let reference = LinearImage::read_exr(&repo().join("tests/data/cornell-glossy-64.exr")).unwrap();
    check_cached_reference(&ctx, &glossy("true"), &reference);
    let ratios = |specular: &str| {
        let (out, scene) = render(&ctx, glossy(specular));
        let map = RegionMap::trace(&scene, 64, 64);
        region_stats(&map, &Pair { test: &linear(&out), reference: &reference, reference_variance: None })
    };
    let (with, without) = (ratios("true"), ratios("false"));
    let mut report = String::new();
    for s in with.iter().filter(|s| s.grouping == Grouping::Mesh) {
        report += &format!("{} {:.3}; ", s.name, s.ratio);
        assert!((0.6..=1.65).contains(&s.ratio), "{}: {:.3} of the reference", s.name, s.ratio);
    }
    eprintln!("glossy Cornell box, image {:.3}, by mesh: {report}", with[0].ratio);
    assert!((0.88..=1.08).contains(&with[0].ratio), "image energy {:.3}", with[0].ratio);
    for glossy_mesh in ["sphere", "shortBox"] {
        let name = format!("CornellBox-Glossy-Floor/{glossy_mesh}");
        let (a, b) = (stats(&with, Grouping::Mesh, &name).ratio, stats(&without, Grouping::Mesh, &name).ratio);
        assert!(a > b + 0.3, "{glossy_mesh}: {a:.3} with the specular cone, {b:.3} without");
    }
}

/// Bounce feedback: n updates of one bounce each, each gathering the previous update's bounced
/// light, give the light of n bounces in one update; and after the light moves, a few updates
/// bring the image to what a fresh render at the new position shows (the lag is the price).
#[test]
fn bounce_feedback_accumulates_over_updates_and_follows_motion() {
    let ctx = context();
    let scene = |extra: &[(&str, &str)]| {
        // Every voxel gathers in every update (no interleave): one bounce per update.
        let mut o = vec![
            ("render.width", "32"),
            ("render.height", "32"),
            ("gi.voxel_resolution", "32"),
            ("gi.bounce_interleave", "1"),
        ];
        o.push(("lights.0.motion", "{ velocity = [0, -0.25, 0] }"));
        o.extend_from_slice(extra);
        load(&repo().join("scenes/cornell-box.toml"), &o)
    };
    let mean = |o: &FrameOutput| o.radiance.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>();
    let frames = |r: &mut Renderer, t: f32, n: u32| {
        for _ in 1..n {
            r.render(t, false).unwrap();
        }
        r.render(t, true).unwrap();
        mean(&r.output())
    };
    let mut fed = Renderer::new(&ctx, scene(&[("gi.first_update_bounces", "1")])).unwrap();
    let accumulated = frames(&mut fed, 0.0, 4);
    let mut once = Renderer::new(&ctx, scene(&[("gi.bounce_feedback", "false"), ("gi.bounces", "4")])).unwrap();
    let in_one = frames(&mut once, 0.0, 1);
    drop(once);
    eprintln!("4 updates of 1 bounce: {accumulated:.4}, 1 update of 4 bounces: {in_one:.4}");
    assert!((accumulated / in_one - 1.0).abs() < 0.01, "{accumulated} vs {in_one}");
    // The light drops 25 cm: the first frame after the move still carries the old bounced
    // light, the next ones converge on a fresh render at the new position.
    let mut lag = Vec::new();
    for _ in 0..4 {
        lag.push(frames(&mut fed, 1.0, 1));
    }
    drop(fed);
    let mut fresh = Renderer::new(&ctx, scene(&[("gi.first_update_bounces", "8")])).unwrap();
    let target = frames(&mut fresh, 1.0, 1);
    drop(fresh);
    let errors: Vec<f64> = lag.iter().map(|m| (m / target - 1.0).abs()).collect();
    eprintln!("after the light moved: error of each frame against a fresh render {errors:?}");
    assert!(errors[3] < 0.02, "four updates after the move: {:.4} off", errors[3]);
    assert!(errors[3] <= errors[0], "the error does not shrink: {errors:?}");
    assert_no_validation_messages(&ctx);
}

/// A room 1 m wide and deep and 0.6 m high, normals inward, whose two walls at the far
/// corner (x = 1, z = 1) stop 0.3 m short of it: a slot from floor to ceiling through which
/// light leaves. A point light near the west wall (x = 0) lights it brightly; the floor is
/// split at 0.3 m from that wall, so the strip under the lit wall is its own region.
fn open_corner_room() -> Scene {
    let (h, c) = (0.3, 0.35);
    let floor_near = quad(Vec3::new(0.15, 0.0, 0.5), Vec3::new(0.15, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), Vec3::Y);
    let floor_far = quad(Vec3::new(0.65, 0.0, 0.5), Vec3::new(0.35, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), Vec3::Y);
    let ceiling = quad(Vec3::new(0.5, 2.0 * h, 0.5), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), -Vec3::Y);
    let west = quad(Vec3::new(0.0, h, 0.5), Vec3::new(0.0, h, 0.0), Vec3::new(0.0, 0.0, 0.5), Vec3::X);
    let south = quad(Vec3::new(0.5, h, 0.0), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, h, 0.0), Vec3::Z);
    let east = quad(Vec3::new(1.0, h, c), Vec3::new(0.0, h, 0.0), Vec3::new(0.0, 0.0, c), -Vec3::X);
    let north = quad(Vec3::new(c, h, 1.0), Vec3::new(c, 0.0, 0.0), Vec3::new(0.0, h, 0.0), -Vec3::Z);
    let mut s = scene_of(
        vec![
            mesh("floor by the lit wall", &floor_near, 0, None),
            mesh("floor", &floor_far, 0, None),
            mesh("ceiling", &ceiling, 0, None),
            mesh("lit wall", &west, 0, None),
            mesh("south wall", &south, 0, None),
            mesh("east wall", &east, 0, None),
            mesh("north wall", &north, 0, None),
        ],
        vec![material("white", 0.7, Vec3::ZERO)],
        camera(Vec3::new(0.95, 0.5, 0.05), Vec3::new(0.25, 0.1, 0.8), 90.0),
        vec![point_light(Vec3::new(0.12, 0.45, 0.5), 1.0)],
        Aabb { min: Vec3::splat(-0.05), max: Vec3::splat(1.05) },
    );
    s.settings.width = 48;
    s.settings.height = 48;
    s
}

/// The first update's bounce tail (`gi.bounce_tail`): one frame of the open-corner room, a
/// closed white room where light bounces many times (its fourth and later bounces are 30% of
/// its indirect light), holds with the default 4 bounces and the tail what 16 bounces give,
/// surface by surface, where 4 bounces alone leave out an eighth of it. Measured (lavapipe,
/// 32^3): the tail within 0.5% of 16 bounces on every surface; 4 bounces alone 0.86-0.89.
#[test]
fn the_first_update_adds_the_bounces_it_does_not_run() {
    let ctx = context();
    let mut scene = open_corner_room();
    scene.settings.gi.voxel_resolution = 32;
    scene.settings.view = dvsgi::scene::View::Indirect;
    let map = RegionMap::trace(&scene, 48, 48);
    let indirect = |bounces: u32, tail: bool| {
        let mut s = scene.clone();
        s.settings.gi.first_update_bounces = bounces;
        s.settings.gi.bounce_tail = tail;
        linear(&render(&ctx, s).0)
    };
    let converged = indirect(16, false);
    let ratios = |test: &LinearImage| -> Vec<(String, f64)> {
        let pair = Pair { test, reference: &converged, reference_variance: None };
        let all = region_stats(&map, &pair);
        all.into_iter().filter(|s| s.grouping == Grouping::Mesh && !s.small).map(|s| (s.name, s.ratio)).collect()
    };
    let (tail, four) = (ratios(&indirect(4, true)), ratios(&indirect(4, false)));
    let show = |v: &[(String, f64)]| v.iter().map(|(n, r)| format!("{n} {r:.4}")).collect::<Vec<_>>().join("; ");
    eprintln!("against 16 bounces: 4 and the tail: {}\n4 alone: {}", show(&tail), show(&four));
    assert!(tail.len() >= 6, "surfaces in view: {tail:?}");
    for ((name, with), (_, without)) in tail.iter().zip(&four) {
        assert!((with - 1.0).abs() < 0.01, "{name}: 4 bounces and the tail give {with:.4} of 16 bounces' light");
        assert!(*without < 0.95, "{name}: 4 bounces alone give {without:.4}: the room does not test the tail");
    }
}

/// Issue 43: the indirect light converges as the voxels shrink. In the open-corner room the
/// indirect light of every surface is compared with the path tracer's (full minus direct light,
/// 1024 spp) at 32^3, 64^3 and 128^3, from one frame at the defaults: the first update's 4
/// bounces and their tail hold the converged light (the test above), so what is measured is the
/// voxels, not the bounce count (ACCURACY.md, "A room with an open corner").
///
/// At the defaults every surface is within 0.85..1.15 at 128^3 (the bound), and no
/// surface's error grows by more than 0.05 from one resolution to the next. Measured
/// (lavapipe): 1.02-1.17 at 32^3, 0.97-1.10 at 64^3, 0.94-1.06 at 128^3. The lit wall
/// converges; the others drift by about -3% per doubling, so the north and east walls' errors
/// grow from 0.016 and 0.027 at 64^3 to 0.052 and 0.058 at 128^3: the "does not grow"
/// is not met at the defaults.
///
/// The drift is the walls' edge-on thickness (ACCURACY.md, seventeenth part). With the default
/// `gi.voxel_cover = "touch"` a wall is one voxel thick seen along its own plane, so in a texel
/// of fixed size in the scene it covers half as much with every doubling, and cones that run
/// along walls see less of them. With `"directional"` a plane is open seen edge-on at every
/// grid, and each surface's move from 64^3 to 128^3 is at most 0.46 of its move from 32^3 to
/// 64^3 (with `"touch"`, up to 0.97 of it).
///
/// With `gi.opacity = "layers"` (a wall's whole optical depth at any angle, where the default
/// `"blend"` keeps cos(theta) of it) the surfaces start above the bound, so every surface's
/// error shrinks with every doubling (measured: 1.11-1.29, 1.08-1.24, 1.05-1.22): what the
/// default's leak hides is the cones' over-count of the cover that stays in part of a
/// footprint. With `"layers"` and `"directional"` cover both, the convergence item
/// holds: every error shrinks with every doubling and every surface is within the bound at
/// 128^3 (measured: 1.08-1.25, 1.04-1.17, 1.01-1.149; the smallest margins are the lit wall's
/// 0.149 against 0.15 and the ceiling's 0.120 -> 0.117). All three behaviours are asserted, so
/// that a change to any of these errors shows here.
#[test]
fn indirect_light_converges_as_voxels_shrink() {
    use dvsgi::scene::{
        Opacity::{Blend, Layers},
        VoxelCover,
    };
    let ctx = context();
    let scene = open_corner_room();
    let truth = path_traced_indirect(&ctx, &scene, 1024);
    let map = RegionMap::trace(&scene, 48, 48);
    let errors_by_grid = |opacity: dvsgi::scene::Opacity, cover: VoxelCover| -> Vec<Vec<(String, f64)>> {
        [32u32, 64, 128]
            .into_iter()
            .map(|res| {
                let mut s = scene.clone();
                s.settings.gi.voxel_resolution = res;
                s.settings.gi.opacity = opacity;
                s.settings.gi.voxel_cover = cover;
                s.settings.view = dvsgi::scene::View::Indirect;
                let (out, _) = render(&ctx, s);
                let ind =
                    region_stats(&map, &Pair { test: &linear(&out), reference: &truth, reference_variance: None });
                let meshes: Vec<(String, f64)> = ind
                    .iter()
                    .filter(|s| s.grouping == Grouping::Mesh && !s.small)
                    .map(|s| (s.name.clone(), s.ratio))
                    .collect();
                let report: Vec<String> = meshes.iter().map(|(n, r)| format!("{n} {r:.3}")).collect();
                eprintln!("{opacity:?}, {cover:?}, {res}^3: indirect light / the reference's: {}", report.join("; "));
                meshes
            })
            .collect()
    };
    let blend = errors_by_grid(Blend, VoxelCover::Touch);
    let layers = errors_by_grid(Layers, VoxelCover::Touch);
    let directional = errors_by_grid(Layers, VoxelCover::Directional);
    assert_eq!(scene.settings.gi.opacity, Blend, "the defaults' opacity");
    assert_eq!(scene.settings.gi.voxel_cover, VoxelCover::Touch, "the defaults' cover");
    assert!(blend[0].len() >= 6, "surfaces in view: {:?}", blend[0]);
    let error = |errors: &[Vec<(String, f64)>], i: usize, name: &str| {
        (errors[i].iter().find(|(n, _)| n == name).unwrap().1 - 1.0).abs()
    };
    for (name, _) in &blend[0] {
        let err = |i: usize| error(&blend, i, name);
        assert!(err(1) <= err(0) + 0.05, "{name}: error grows from 32^3 ({:.3}) to 64^3 ({:.3})", err(0), err(1));
        assert!(err(2) <= err(1) + 0.05, "{name}: error grows from 64^3 ({:.3}) to 128^3 ({:.3})", err(1), err(2));
        assert!(err(2) <= 0.15, "{name}: at 128^3 the indirect light is off by {:.3}", err(2));
        let err = |i: usize| error(&layers, i, name);
        assert!(
            err(1) < err(0) && err(2) < err(1),
            "{name}: with layers opacity the error does not shrink: {:.3}, {:.3}, {:.3}",
            err(0),
            err(1),
            err(2)
        );
        let err = |i: usize| error(&directional, i, name);
        assert!(
            err(1) < err(0) && err(2) < err(1) && err(2) <= 0.15,
            "{name}: with layers opacity and directional cover the error does not shrink into the bound: \
             {:.3}, {:.3}, {:.3}",
            err(0),
            err(1),
            err(2)
        );
    }
}

/// `gi.attenuation = "per-side"`: a voxel that holds faces facing different ways shows each
/// side the light of its faces along that side's axis. A block stands on a floor under a sun
/// from +x and above (the top and the +x face lit, the -x face not). The floor on the block's
/// -x side sees no lit face: the -x face is unlit, the top and the +x face are out of sight and
/// the floor cannot see itself, so its one-bounce light is zero (the path tracer's, checked
/// here). What the cones gather there is error, part of it the light of the voxels along the
/// block's top edge, which hold the lit top and the unlit side and which the mean normal's
/// cosine lights to every side. Per-side light must take a fifth of that error away, in the
/// block's shadow and on the sunlit floor beyond it.
#[test]
fn per_side_light_keeps_a_block_s_unlit_side_dark() {
    let ctx = context();
    let floor = quad(Vec3::ZERO, Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), Vec3::Y);
    let (hx, hy, hz) = (0.1, 0.1, 0.25);
    let c = Vec3::new(0.0, hy, 0.0);
    let mut block = Vec::new();
    block.extend(quad(c + Vec3::Y * hy, Vec3::X * hx, Vec3::Z * hz, Vec3::Y));
    block.extend(quad(c + Vec3::X * hx, Vec3::Y * hy, Vec3::Z * hz, Vec3::X));
    block.extend(quad(c - Vec3::X * hx, Vec3::Y * hy, Vec3::Z * hz, -Vec3::X));
    block.extend(quad(c + Vec3::Z * hz, Vec3::X * hx, Vec3::Y * hy, Vec3::Z));
    block.extend(quad(c - Vec3::Z * hz, Vec3::X * hx, Vec3::Y * hy, -Vec3::Z));
    let sun = sun(Vec3::new(-0.6, -0.8, 0.0));
    let make = |attenuation: dvsgi::scene::VoxelAttenuation| {
        let mut s = scene_of(
            vec![mesh("floor", &floor, 0, None), mesh("block", &block, 0, None)],
            vec![material("white", 0.8, Vec3::ZERO)],
            camera(Vec3::new(-0.7, 0.6, 0.0), Vec3::new(-0.1, 0.0, 0.0), 60.0),
            vec![sun.clone()],
            Aabb { min: Vec3::splat(-0.55), max: Vec3::splat(0.55) },
        );
        s.settings.width = 64;
        s.settings.height = 64;
        s.settings.gi.bounces = 0;
        s.settings.gi.first_update_bounces = 0;
        s.settings.gi.attenuation = attenuation;
        s
    };
    let scene = make(dvsgi::scene::VoxelAttenuation::NDotL);
    let tris = triangles(&scene, 0.0);
    // Floor pixels in the block's shadow (it ends at x = -0.1 - 0.2 * 0.75 = -0.25), and on the
    // floor beyond it.
    let on_floor = |i: usize, lo: f32, hi: f32| {
        let (o, d) = camera_ray(&scene, (i % 64) as u32, (i / 64) as u32);
        raycast(&tris, o, d, 1e-4, 1e4)
            .map(|(t, _)| o + d * t)
            .is_some_and(|p| p.y.abs() < 1e-3 && p.x > lo && p.x < hi && p.z.abs() < 0.2)
    };
    let one_bounce = {
        let trace = |max_bounces: Option<u32>| {
            let options = ReferenceOptions { spp: 256, max_bounces, ..Default::default() };
            let mut pt = PathTracer::new(&ctx, &scene, options).unwrap();
            pt.run(|_, _| {}).unwrap();
            let img = pt.image().unwrap();
            LinearImage { width: img.width, height: img.height, rgb: img.mean }
        };
        minus(&trace(Some(1)), &trace(Some(0)))
    };
    let indirect = |attenuation| {
        let mut s = make(attenuation);
        s.settings.view = dvsgi::scene::View::Indirect;
        linear(&render(&ctx, s).0)
    };
    let (mean_light, per_side) =
        (indirect(dvsgi::scene::VoxelAttenuation::NDotL), indirect(dvsgi::scene::VoxelAttenuation::PerSide));
    let mean = |img: &LinearImage, lo: f32, hi: f32| {
        let (mut sum, mut n) = (0.0f64, 0usize);
        for i in 0..64 * 64 {
            if on_floor(i, lo, hi) {
                sum += img.rgb[3 * i..3 * i + 3].iter().map(|&v| f64::from(v)).sum::<f64>();
                n += 1;
            }
        }
        assert!(n >= 30, "{n} floor pixels in {lo}..{hi}");
        sum / n as f64
    };
    for (what, lo, hi) in [("in the block's shadow", -0.24, -0.12), ("in the sun beyond it", -0.45, -0.3)] {
        let (truth, before, after) = (mean(&one_bounce, lo, hi), mean(&mean_light, lo, hi), mean(&per_side, lo, hi));
        eprintln!("the floor {what}, one bounce: path tracer {truth:.4}, n-dot-l {before:.4}, per-side {after:.4}");
        assert!(truth.abs() < 2e-3, "the path tracer's floor {what} sees no lit face: {truth:.4}");
        assert!(before > 0.01, "the cones' error to take away {what}: {before:.4}");
        assert!(
            after < 0.8 * before,
            "per-side light keeps the block's unlit side dark {what}: {after:.4} vs {before:.4}"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// `gi.attenuation = "per-side"` on a surface that is not made of faces along the axes: a wall
/// facing +x, corrugated along y with facets whose normals are (0.8, +-0.6, 0) and ridges finer
/// than a voxel, so every voxel of it holds both facets (mean normal (0.8, 0, 0), shorter than
/// `ONE_PLANE`). A sun from +x, level with the wall's middle, lights both facets at 0.8 of its
/// irradiance. Seen from +x a voxel shows both facets and from -y the one facing down: 0.8 of
/// the irradiance from either side, the facets' own light. The mean normal's cosine gives the
/// voxel 1 to every side, and faces along the axes would give the -y side none. The voxel-mip
/// view of the directional volumes' first level, where the side factors apply (13/16 for 0.8),
/// must show 0.8 of the mean normal's light from both sides.
#[test]
fn per_side_light_shows_a_corrugated_wall_s_facets_from_each_side() {
    use dvsgi::scene::{View, ViewDirection, VoxelAttenuation};
    let ctx = context();
    // Facets of 0.01 along y and 0.0075 along x (slope 0.75: normals (0.8, +-0.6, 0)).
    let (rise, run, x0) = (0.01f32, 0.0075f32, -0.1f32);
    let mut wall = Vec::new();
    for k in 0..15 {
        let y = -0.15 + 2.0 * rise * k as f32;
        let (a, b, c) = (Vec3::new(x0, y, 0.0), Vec3::new(x0 + run, y + rise, 0.0), Vec3::new(x0, y + 2.0 * rise, 0.0));
        let half_z = Vec3::Z * 0.25;
        wall.extend(quad((a + b) * 0.5, (b - a) * 0.5, half_z, Vec3::new(0.8, -0.6, 0.0)));
        wall.extend(quad((b + c) * 0.5, (c - b) * 0.5, half_z, Vec3::new(0.8, 0.6, 0.0)));
    }
    let shown = |attenuation: VoxelAttenuation, direction: ViewDirection| {
        let mut s = scene_of(
            vec![mesh("wall", &wall, 0, None)],
            vec![material("white", 0.8, Vec3::ZERO)],
            camera(Vec3::new(0.6, 0.0, 0.0), Vec3::new(-0.1, 0.0, 0.0), 60.0),
            vec![sun(Vec3::new(-1.0, 0.0, 0.0))],
            Aabb { min: Vec3::splat(-0.55), max: Vec3::splat(0.55) },
        );
        s.settings.width = 32;
        s.settings.height = 32;
        s.settings.gi.voxel_resolution = 32;
        s.settings.gi.bounces = 0;
        s.settings.gi.first_update_bounces = 0;
        s.settings.gi.attenuation = attenuation;
        s.settings.view = View::VoxelMip;
        s.settings.view_lod = 1.0;
        s.settings.view_direction = direction;
        let img = linear(&render(&ctx, s).0);
        img.rgb.iter().map(|&v| f64::from(v)).sum::<f64>()
    };
    // A cone travelling -x sees the +x side; one travelling +y the -y side.
    for (side, direction) in [("+x", ViewDirection::NegX), ("-y", ViewDirection::PosY)] {
        let (mean_light, per_side) =
            (shown(VoxelAttenuation::NDotL, direction), shown(VoxelAttenuation::PerSide, direction));
        eprintln!("the wall from its {side} side: n-dot-l {mean_light:.3}, per-side {per_side:.3}");
        assert!(mean_light > 1.0, "the wall is lit and in view: {mean_light:.3}");
        let ratio = per_side / mean_light;
        assert!(
            (ratio - 0.8125).abs() < 0.03,
            "per-side light shows the {side} side its facets' light: {ratio:.3} of the mean normal's"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// `gi.plane_backs = "dark"` (glsl/aniso_mip.comp): a sunlit plate's voxels do not light the
/// floor in its shadow from behind. A white plate 0.47 m over a white floor, a sun nearly straight
/// down; the camera, under the plate, sees only the plate's shadow on the floor, whose indirect
/// light comes from the plate's underside (lit by the sunlit floor around: the path tracer's
/// second bounce) and nothing else (a floor does not see itself). With every voxel lit to
/// every side the plate's sunlit voxels light that floor through the filtered volumes.
#[test]
fn a_sunlit_plate_does_not_light_the_floor_under_it_from_behind() {
    let ctx = context();
    let floor = quad(Vec3::new(0.5, 0.045, 0.5), Vec3::new(0.45, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.45), Vec3::Y);
    let plate = quad(Vec3::new(0.5, 0.515, 0.5), Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.2), Vec3::Y);
    let scene = |backs: dvsgi::scene::PlaneBacks| {
        let mut s = scene_of(
            vec![mesh("floor", &floor, 0, None), mesh("plate", &plate, 0, None)],
            vec![material("white", 0.8, Vec3::ZERO)],
            Camera { up: Vec3::Z, ..camera(Vec3::new(0.5, 0.3, 0.5), Vec3::new(0.5, 0.0, 0.5), 40.0) },
            vec![sun(Vec3::new(0.05, -1.0, 0.03))],
            Aabb { min: Vec3::ZERO, max: Vec3::ONE },
        );
        s.settings.gi.voxel_resolution = 32;
        s.settings.gi.plane_backs = backs;
        s
    };
    let mean = |rgb: &[f32]| rgb.iter().map(|&v| f64::from(v)).sum::<f64>() / rgb.len() as f64;
    let truth = mean(&path_traced_indirect(&ctx, &scene(dvsgi::scene::PlaneBacks::Lit), 256).rgb);
    let cones = |backs| {
        let mut s = scene(backs);
        s.settings.view = dvsgi::scene::View::Indirect;
        let (out, _) = render(&ctx, s);
        mean(&linear(&out).rgb)
    };
    let (lit, dark) = (cones(dvsgi::scene::PlaneBacks::Lit), cones(dvsgi::scene::PlaneBacks::Dark));
    eprintln!("floor under the plate: indirect {truth:.5} (path tracer), {lit:.5} (lit backs), {dark:.5} (dark backs)");
    assert!(lit > 2.0 * truth, "lit backs {lit:.5}, path tracer {truth:.5}: the test no longer sees the leak");
    assert!((dark - truth).abs() < 0.5 * (lit - truth), "dark backs {dark:.5}, lit {lit:.5}, path tracer {truth:.5}");
    // The plate is an open surface: its back closes no solid, so "closed" leaves it as "dark" does.
    let closed = cones(dvsgi::scene::PlaneBacks::Closed);
    assert_eq!(closed, dark, "an open plate's back: closed {closed:.5}, dark {dark:.5}");
    assert_no_validation_messages(&ctx);
}

/// `gi.plane_backs = "closed"` (glsl/voxel_backs.comp): a cone starts outside every solid, so
/// the rays of it that reach a block's far side or its top from under it met the block's front
/// first. With the backs in (`"dark"`) each block blocked a cone's partial footprint twice, at
/// its front and again at its back, and the Cornell box's floor, whose near-horizon cones pass
/// the blocks, lost a fifth of its light; with the backs that close a solid left out it is
/// lit as with lit backs (64x64, 64^3, lavapipe: floor 0.80 dark, 0.92 closed, 0.91 lit; the
/// blocks' fronts 0.94 and 0.95 dark, 1.02 and 1.04 closed). The closed emissive box still
/// returns rho Le: no wall opens (its faces' backs face the outside, where nothing closes them).
#[test]
fn backs_that_close_a_solid_do_not_block_a_cone_twice() {
    let ctx = context();
    let rho_le = 0.5;
    let mean = furnace_one_bounce(&ctx, |s| s.settings.gi.plane_backs = dvsgi::scene::PlaneBacks::Closed);
    eprintln!("one bounce in the closed box with closed backs: {mean:.4} (rho Le = {rho_le})");
    assert!((mean / rho_le - 1.0).abs() < 0.06, "closed backs: {mean:.4} vs {rho_le}");

    let indirect = |backs: &str| cornell_indirect_with(&ctx, &[("gi.plane_backs", backs)]);
    let (dark, closed) = (indirect("\"dark\""), indirect("\"closed\""));
    for (name, gain) in [("floor +y", 0.08), ("tallBlock -z", 0.05), ("shortBlock -z", 0.05)] {
        let region = format!("box/{name}");
        let ratio = |r: &[RegionStats]| stats(r, Grouping::Surface, &region).ratio;
        let (d, c) = (ratio(&dark), ratio(&closed));
        eprintln!("{name}: indirect {d:.3} of the reference's with dark backs, {c:.3} with closed ones");
        assert!(c > d + gain && (0.85..=1.15).contains(&c), "{name}: dark backs {d:.3}, closed {c:.3}");
    }
    assert_no_validation_messages(&ctx);
}

//! Numerical stability at the extremes (lavapipe, validation on, small images and grids): every
//! knob at both ends of its range, light intensities from 0 to 1e6, scene scales from 1e-3 to
//! 1e4 units, and degenerate geometry. For every case every image and volume the frame created
//! is read back: no NaN or Inf, no 16-bit value at the half-float ceiling (an overflow that was
//! clamped), no negative radiance, and the image's radiance within what energy conservation
//! allows for the scene's albedos and lights. Linearity in light intensity and invariance under
//! scene scale are checked against the unit case.

mod common;

use common::*;
use dvsgi::gpu::Context;
use dvsgi::render::{FrameOutput, Renderer};
use dvsgi::scene::*;
use glam::{Mat4, Vec3};
use std::path::PathBuf;
use std::sync::Arc;

const HALF_MAX: f32 = 65504.0;

/// The Cornell box (Lambertian, albedo <= 0.725, one point light 5 cm under the ceiling) at
/// 24x24 pixels, 16^3 voxels, one bounce, specular, AO and cone shadows as the scene file says.
fn cornell(overrides: &[(&str, &str)]) -> Scene {
    let mut all = vec![
        ("render.width", "24"),
        ("render.height", "24"),
        ("render.shadow_map_size", "128"),
        ("gi.voxel_resolution", "16"),
    ];
    all.extend_from_slice(overrides);
    common::load(&repo().join("scenes/cornell-box.toml"), &all)
}

/// Upper bound on any outgoing radiance of a Lambertian scene: with emission at most Le,
/// albedo at most rho < 1 and direct irradiance at most E (every light at its nearest surface),
/// L <= Le + rho/pi E + rho L_max, so L_max <= (Le + rho/pi E) / (1 - rho). None when the scene
/// is not Lambertian or not absorbing.
fn energy_bound(scene: &Scene) -> Option<f32> {
    let rho = scene.materials.iter().map(|m| m.albedo.max_element()).fold(0.0f32, f32::max);
    if rho >= 1.0 || scene.materials.iter().any(|m| m.is_glossy() || m.albedo_texture.is_some()) {
        return None;
    }
    let le = scene.materials.iter().map(|m| m.emission.max_element()).fold(0.0f32, f32::max);
    let t = scene.settings.time;
    let tris = triangles(scene, t);
    let mut e = 0.0f64;
    for l in &scene.lights {
        match l.at_time(t) {
            LightKind::Directional { irradiance, .. } => e += irradiance.max_element() as f64,
            LightKind::Point { position, intensity } | LightKind::Spot { position, intensity, .. } => {
                let d = tris.iter().map(|tr| point_triangle_distance(position, tr)).fold(f32::INFINITY, f32::min);
                if intensity.max_element() > 0.0 {
                    e += intensity.max_element() as f64 / (d as f64 * d as f64);
                }
            }
        }
    }
    Some(((le as f64 + rho as f64 / std::f64::consts::PI * e) / (1.0 - rho as f64)) as f32)
}

/// Distance from p to the closest point of a triangle (Ericson, Real-Time Collision Detection 5.1.5).
fn point_triangle_distance(p: Vec3, t: &Triangle) -> f32 {
    let (a, b, c) = (t.a, t.b, t.c);
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return p.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    p.distance(a + ab * (vb * denom) + ac * (vc * denom))
}

/// What one case produced.
struct Checked {
    out: FrameOutput,
    /// Names of the image levels read back.
    read: Vec<String>,
}

/// Render `frames` frames of `scene`, read back every image level, and check the invariants.
fn check(ctx: &Arc<Context>, label: &str, scene: Scene, frames: u32) -> Checked {
    let bound = energy_bound(&scene);
    let t = scene.settings.time;
    let mut r = Renderer::new(ctx, scene).unwrap_or_else(|e| panic!("{label}: {e}"));
    for _ in 0..frames {
        r.render(t, true).unwrap_or_else(|e| panic!("{label}: {e}"));
    }
    let out = r.output();
    let mut read = Vec::new();
    for img in r.all_images() {
        for level in 0..img.desc.mip_levels {
            let Some(v) = float_texels(&mut r, &img, level) else { continue };
            let name = format!("{label}: {} level {level}", img.name);
            let bad = v.iter().filter(|x| !x.is_finite()).count();
            assert_eq!(bad, 0, "{name}: {bad} of {} floats are NaN/Inf", v.len());
            if img.desc.format == ash::vk::Format::R16G16B16A16_SFLOAT {
                let top = v.iter().fold(0.0f32, |m, x| m.max(x.abs()));
                assert!(top < HALF_MAX, "{name}: a value reached the half-float ceiling (overflow)");
            }
            read.push(name);
        }
    }
    drop(r);
    assert_no_validation_messages(ctx);
    let rgb = || out.radiance.chunks_exact(4).flat_map(|p| p[..3].iter().copied());
    assert!(rgb().all(|v| v.is_finite()), "{label}: image has NaN/Inf");
    let low = rgb().fold(f32::INFINITY, f32::min);
    assert!(low >= 0.0, "{label}: negative radiance {low}");
    let high = rgb().fold(0.0f32, f32::max);
    eprintln!("{label}: {} levels read back, image max {high:.4e}, energy bound {bound:?}", read.len());
    if let Some(b) = bound {
        assert!(high <= b * 1.001, "{label}: radiance {high} exceeds the energy bound {b}");
    }
    Checked { out, read }
}

fn mean(out: &FrameOutput) -> f64 {
    out.radiance.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / (3 * out.width * out.height) as f64
}

/// Largest per-pixel difference of `a` and `b * scale`, relative to the image's peak.
fn rel_diff(a: &FrameOutput, b: &FrameOutput, scale: f32) -> f32 {
    let peak = a.radiance.iter().fold(0.0f32, |m, v| m.max(v.abs())).max(1e-30);
    a.radiance
        .chunks_exact(4)
        .zip(b.radiance.chunks_exact(4))
        .flat_map(|(p, q)| (0..3).map(move |i| (p[i] - q[i] * scale).abs()))
        .fold(0.0f32, f32::max)
        / peak
}

#[test]
fn knobs_at_both_ends_stay_finite_and_bounded() {
    let ctx = context();
    let cases: &[(&str, &[(&str, &str)])] = &[
        ("voxels 8", &[("gi.voxel_resolution", "8")]),
        ("voxels 128", &[("gi.voxel_resolution", "128")]),
        // 256^3 is the largest grid within lavapipe's 2 GiB heap (512^3 is refused up front:
        // tests/limits.rs); no bounce, which alone takes ~45 s of CPU there.
        ("voxels 256", &[("gi.voxel_resolution", "256"), ("gi.bounces", "0")]),
        ("aperture 0.5", &[("gi.diffuse_cone_angle", "0.5"), ("gi.shadow_cone_angle", "0.5")]),
        ("aperture 170", &[("gi.diffuse_cone_angle", "170"), ("gi.shadow_cone_angle", "170")]),
        ("step 0.05", &[("gi.step", "0.05"), ("gi.shadows", "\"cone\"")]),
        ("step 2", &[("gi.step", "2"), ("gi.shadows", "\"cone\"")]),
        ("bounces 0", &[("gi.bounces", "0")]),
        ("downsample 8", &[("gi.downsample", "8")]),
        ("downsample 3", &[("gi.downsample", "3"), ("render.width", "25"), ("render.height", "23")]),
        ("1x1 image", &[("render.width", "1"), ("render.height", "1"), ("gi.downsample", "8")]),
        ("offset 0, ao falloff 0", &[("gi.start_offset", "0"), ("gi.ao_falloff", "0")]),
        ("voxel shadows", &[("gi.occlusion", "\"raymarch\""), ("gi.voxel_shadow_softness", "1")]),
        ("max distance tiny", &[("gi.max_distance", "1e-6")]),
        ("exposure -20", &[("render.exposure", "-20")]),
        ("exposure +20", &[("render.exposure", "20")]),
    ];
    let mut levels = 0;
    for (label, o) in cases {
        levels += check(&ctx, label, cornell(o), 1).read.len();
    }
    // Every level of every volume of every case was looked at.
    assert!(levels > 200, "only {levels} image levels read back");
}

/// Bounces 0..=8: every case bounded, the indirect light grows with each bounce and the
/// increments shrink (a geometric series with ratio below the largest albedo).
#[test]
fn indirect_light_never_explodes_with_bounces() {
    let ctx = context();
    let mut means = Vec::new();
    for b in 0..=8 {
        let n = b.to_string();
        let c = check(
            &ctx,
            &format!("bounces {b}"),
            cornell(&[("gi.bounces", &n), ("gi.bounce_feedback", "false"), ("render.view", "\"indirect\"")]),
            1,
        );
        means.push(mean(&c.out));
    }
    eprintln!("mean indirect radiance for bounces 0..=8: {means:?}");
    let steps: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).collect();
    let noise = 3e-3 * means[0];
    assert!(steps.iter().all(|&s| s > -noise), "a bounce made the indirect light darker: {means:?}");
    for w in steps.windows(2) {
        assert!(w[1] <= 0.725 * w[0] + noise, "bounce increments do not shrink: {means:?}");
    }
}

/// Light intensity 0 gives exactly black everywhere; 1e-6 and 1e6 give the unit image scaled
/// (no underflow or overflow in the 16-bit volumes, the G-buffer or the cone targets).
#[test]
fn light_intensity_from_zero_to_a_million_is_linear() {
    let ctx = context();
    let unit = check(&ctx, "intensity 1.2", cornell(&[]), 1).out;
    let zero = check(&ctx, "intensity 0", cornell(&[("lights.0.intensity", "[0, 0, 0]")]), 1).out;
    assert!(zero.radiance.chunks_exact(4).all(|p| p[..3] == [0.0; 3]), "no light is not black");
    for s in [1e-6f32, 1e6] {
        let i = (1.2 * s).to_string();
        let o =
            check(&ctx, &format!("intensity {i}"), cornell(&[("lights.0.intensity", &format!("[{i}, {i}, {i}]"))]), 1);
        let d = rel_diff(&unit, &o.out, 1.0 / s);
        eprintln!("intensity x{s}: largest difference {d:.2e} of the peak");
        assert!(d < 0.02, "intensity x{s}: image differs from the scaled unit image by {d} of its peak");
    }
}

/// Emission from 1e-6 to 1e6 W/(sr m^2): an emissive panel in place of the point light.
#[test]
fn emission_from_a_millionth_to_a_million_is_linear() {
    let ctx = context();
    let panel = |le: f32| {
        let mut s = cornell(&[]);
        s.lights.clear();
        let m = s.materials.len() as u32;
        s.materials.push(Material {
            name: "panel".into(),
            albedo: Vec3::splat(0.5),
            albedo_texture: None,
            mask_texture: None,
            normal_texture: None,
            relief: Relief::default(),
            specular: Vec3::ZERO,
            shininess: 1.0,
            emission: Vec3::splat(le),
        });
        let (y, a, b) = (0.54, 0.2, 0.35);
        let quad = [Vec3::new(a, y, a), Vec3::new(b, y, a), Vec3::new(b, y, b), Vec3::new(a, y, b)];
        s.meshes.push(mesh("panel", &[[quad[0], quad[2], quad[1]], [quad[0], quad[3], quad[2]]], m, None));
        s.objects.push(object(s.meshes.len() - 1));
        s
    };
    let unit = check(&ctx, "emission 1", panel(1.0), 1).out;
    assert!(mean(&unit) > 0.0);
    for s in [1e-6f32, 1e6] {
        let o = check(&ctx, &format!("emission {s}"), panel(s), 1);
        let d = rel_diff(&unit, &o.out, 1.0 / s);
        eprintln!("emission x{s}: largest difference {d:.2e} of the peak");
        assert!(d < 0.02, "emission x{s}: image differs from the scaled unit image by {d} of its peak");
    }
}

/// The whole scene scaled by 1e-3 and 1e4 (geometry, camera, light positions; intensities by
/// the square so irradiance is unchanged) renders the same image as at unit scale.
#[test]
fn scene_scale_from_a_thousandth_to_ten_thousand_units_is_invariant() {
    let ctx = context();
    let unit = check(&ctx, "scale 1", cornell(&[]), 1).out;
    for k in [1e-3f32, 1e4] {
        let mut s = cornell(&[]);
        for m in &mut s.meshes {
            m.positions.iter_mut().for_each(|p| *p *= k);
            m.bounds = Aabb { min: m.bounds.min * k, max: m.bounds.max * k };
        }
        let c = &mut s.camera;
        c.position *= k;
        c.target *= k;
        c.near *= k;
        c.far *= k;
        for l in &mut s.lights {
            if let LightKind::Point { position, intensity } = &mut l.kind {
                *position *= k;
                *intensity *= k * k;
            }
        }
        let o = check(&ctx, &format!("scale {k}"), s, 1);
        let d = rel_diff(&unit, &o.out, 1.0);
        eprintln!("scale {k}: largest difference {d:.2e} of the peak");
        assert!(d < 0.02, "scale {k}: image differs from the unit-scale image by {d} of its peak");
    }
}

fn object(mesh: usize) -> Object {
    Object {
        name: format!("o{mesh}"),
        meshes: vec![mesh as u32],
        transform: Mat4::IDENTITY,
        dynamic: false,
        motion: Motion::None,
    }
}

/// A scene of the given triangles (albedo 0.5), a point light above, the camera looking down.
fn scene_of(tris: &[[Vec3; 3]], normal: Option<Vec3>) -> Scene {
    let mut s = Scene {
        sky: None,
        path: PathBuf::from("extremes"),
        name: "extremes".into(),
        meshes: vec![],
        objects: vec![],
        materials: vec![Material::diffuse("grey", Vec3::splat(0.5))],
        textures: vec![],
        camera: Camera {
            position: Vec3::new(0.3, 2.0, 1.5),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 60.0,
            near: 0.01,
            far: 100.0,
        },
        lights: vec![Light {
            name: "l".into(),
            kind: LightKind::Point { position: Vec3::new(0.2, 1.0, 0.1), intensity: Vec3::splat(2.0) },
            cast_shadows: true,
            motion: Motion::None,
        }],
        settings: RenderSettings {
            width: 24,
            height: 24,
            shadow_map_size: 128,
            gi: GiSettings { voxel_resolution: 16, bounces: 2, shadows: DirectShadows::Cone, ..Default::default() },
            ..Default::default()
        },
        bounds: None,
    };
    if !tris.is_empty() {
        s.meshes.push(mesh("m", tris, 0, normal));
        s.objects.push(object(0));
    }
    s
}

#[test]
fn degenerate_scenes_stay_finite_and_bounded() {
    let ctx = context();
    let v = Vec3::new;
    let floor = [[v(-1., 0., -1.), v(1., 0., 1.), v(1., 0., -1.)], [v(-1., 0., -1.), v(-1., 0., 1.), v(1., 0., 1.)]];
    let wall = [[v(-1., 0., -1.), v(1., 1., -1.), v(1., 0., -1.)]];
    let flat: Vec<[Vec3; 3]> = floor.to_vec();
    check(&ctx, "flat scene", scene_of(&flat, None), 2);
    check(&ctx, "single triangle", scene_of(&wall, None), 1);
    check(&ctx, "empty scene", scene_of(&[], None), 1);
    let mut degenerate = flat.clone();
    degenerate.push([v(0., 0.5, 0.), v(0., 0.5, 0.), v(0., 0.5, 0.)]); // a point
    degenerate.push([v(-1., 0.2, 0.), v(0., 0.2, 0.), v(1., 0.2, 0.)]); // collinear
    degenerate.push([v(0., 0.3, 0.), v(1e-9, 0.3, 0.), v(0., 0.3, 1e-9)]); // 5e-19 m^2
    check(&ctx, "degenerate and zero-area triangles", scene_of(&degenerate, None), 1);
    check(&ctx, "zero-length normals", scene_of(&flat, Some(Vec3::ZERO)), 1);
    // Every triangle degenerate: geometry with no area at all.
    check(&ctx, "only degenerate triangles", scene_of(&degenerate[2..], None), 1);

    // The light exactly on the surface (distance 0) and in a voxel's centre.
    let mut s = scene_of(&flat, None);
    s.lights[0].kind = LightKind::Point { position: v(0.0, 0.0, 0.0), intensity: Vec3::splat(2.0) };
    check(&ctx, "light on the surface", s, 1);

    // A spot light with no smooth edge (inner = outer), nearly a ray, and one of 89 degrees;
    // a directional light grazing the floor.
    for (inner, outer) in [(0.5, 0.5), (89.0, 89.0), (0.0, 89.0)] {
        let mut s = scene_of(&flat, None);
        s.lights[0].kind = LightKind::Spot {
            position: v(0.2, 1.0, 0.1),
            direction: v(0.0, -1.0, 0.0),
            intensity: Vec3::splat(2.0),
            inner_deg: inner,
            outer_deg: outer,
        };
        check(&ctx, &format!("spot {inner}..{outer} degrees"), s, 1);
    }
    let mut s = scene_of(&flat, None);
    s.lights[0].kind = LightKind::Directional { direction: v(1.0, -1e-7, 0.0), irradiance: Vec3::splat(3.0) };
    check(&ctx, "grazing directional light", s, 1);

    // Camera inside the tall block, and far outside the voxel grid.
    let mut s = cornell(&[]);
    s.camera.position = Vec3::new(0.37, 0.2, 0.35);
    s.camera.target = Vec3::new(0.37, 0.2, 0.0);
    check(&ctx, "camera inside geometry", s, 1);
    // 3 m in front of the open side (the grid ends 3 cm in front of it), a narrow field of view.
    let mut s = cornell(&[]);
    s.camera.position = Vec3::new(0.278, 0.273, -3.0);
    s.camera.fov_y_deg = 12.0;
    let outside = check(&ctx, "camera outside the voxel grid", s, 1).out;
    assert!(mean(&outside) > 0.0, "the lit box is seen from outside the grid");
    let mut s = cornell(&[]);
    s.camera.position = Vec3::new(3.0, 4.0, 5.0);
    s.camera.target = Vec3::new(0.278, 0.273, 0.28);
    check(&ctx, "camera outside looking back", s, 1);
}

/// A texture over the device's maxImageDimension2D (a strip 1.25 times the limit: 20480 x 1 on
/// lavapipe, 40960 x 1 on an H200) is downscaled with a warning naming it, not refused, and keeps
/// its mean colour: a square facing a sun of irradiance pi shows its albedo as radiance.
#[test]
fn a_texture_over_the_device_limit_is_downscaled_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Red 200, green alternating 255 / 0 (a mean of 0.5 in linear light), blue 50.
    let limit = context().info.limits.max_image_dimension2_d;
    let width = limit + limit / 4;
    let strip = image::RgbImage::from_fn(width, 1, |x, _| image::Rgb([200, if x % 2 == 0 { 255 } else { 0 }, 50]));
    strip.save(d.join("strip.png")).unwrap();
    std::fs::write(
        d.join("q.obj"),
        "mtllib q.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl s\nf 1/1/1 2/2/1 3/3/1 4/4/1\n",
    )
    .unwrap();
    std::fs::write(d.join("q.mtl"), "newmtl s\nKd 1 1 1\nmap_Kd strip.png\n").unwrap();
    std::fs::write(
        d.join("s.toml"),
        "[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\n[render]\nwidth = 16\nheight = 16\n[gi]\nmode = \"none\"\n\
         [[objects]]\nobj = \"q.obj\"\n[[lights]]\ntype = \"directional\"\ndirection = [0, 0, -1]\n\
         irradiance = [3.14159265, 3.14159265, 3.14159265]\ncast_shadows = false\n",
    )
    .unwrap();
    let exr = d.join("s.exr");
    let o = dvsgi_with(&["render", d.join("s.toml").to_str().unwrap(), "--out", exr.to_str().unwrap()], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("strip.png) is {width}x1"))
            && stderr(&o).contains(&format!("downscaled to {}x1", width / 2)),
        "{}",
        stderr(&o)
    );
    let img = dvsgi::output::read_rgb_f32(&exr).unwrap();
    // The centre pixel sees the middle of the strip, far inside the square.
    let c = ((img.height / 2 * img.width + img.width / 2) * 3) as usize;
    let srgb = |code: f32| ((code / 255.0 + 0.055) / 1.055).powf(2.4);
    let want = [srgb(200.0), 0.5, srgb(50.0)];
    for (k, (&got, want)) in img.data[c..c + 3].iter().zip(want).enumerate() {
        assert!((got - want).abs() < 0.02 * want.max(0.1), "channel {k}: {got} against {want}");
    }
}

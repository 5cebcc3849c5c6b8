//! GPU tests on the real device (lavapipe in CI) with validation on: any validation message
//! fails the test.

mod common;

use common::*;
use dvsgi::scene::LightKind;
use glam::Vec3;

const SIZE: &str = "160";

fn cornell(overrides: &[(&str, &str)]) -> dvsgi::scene::Scene {
    // Direct light only: these tests check the analytic direct term.
    let mut all = vec![("render.width", SIZE), ("render.height", SIZE), ("gi.mode", "\"none\"")];
    all.extend_from_slice(overrides);
    load(&repo().join("scenes/cornell-box.toml"), &all)
}

fn point_light(scene: &dvsgi::scene::Scene) -> (Vec3, Vec3) {
    match scene.lights[0].at_time(0.0) {
        LightKind::Point { position, intensity } => (position, intensity),
        k => panic!("cornell-box.toml should have a point light, has {k:?}"),
    }
}

fn is_floor(t: &Triangle) -> bool {
    t.a.y.abs() < 1e-5 && t.b.y.abs() < 1e-5 && t.c.y.abs() < 1e-5
}

/// Radiance of the floor straight under the point light equals I cos/d^2 * albedo/pi within
/// 2%, computed at the exact point the pixel sees (camera looking straight down, since the
/// short block hides that point from the classic view); no NaN/Inf.
#[test]
fn cornell_floor_under_light_matches_inverse_square_law() {
    let ctx = context();
    let base = cornell(&[]);
    let (light_pos, intensity) = point_light(&base);
    let eye = format!("[{}, 0.40, {}]", light_pos.x, light_pos.z);
    let target = format!("[{}, 0.0, {}]", light_pos.x, light_pos.z);
    let scene = cornell(&[("camera.position", &eye), ("camera.target", &target), ("camera.up", "[0, 0, 1]")]);
    let (out, scene) = render(&ctx, scene);
    assert!(out.radiance.iter().all(|v| v.is_finite()), "non-finite radiance");
    let tris = triangles(&scene, 0.0);

    let under = Vec3::new(light_pos.x, 0.0, light_pos.z);
    let (px, py) = project(&scene, under);
    let (o, d) = camera_ray(&scene, px, py);
    let (dist, tri) = raycast(&tris, o, d, 1e-4, 1e4).expect("camera ray hits the box");
    assert!(is_floor(&tris[tri]), "pixel ({px},{py}) must see the floor");
    let p = o + d * dist;
    assert!((p - under).length() < 0.01, "pixel sees {p}, not the point under the light {under}");
    assert!(
        raycast(&tris, p + Vec3::Y * 1e-4, (light_pos - p).normalize(), 1e-4, (light_pos - p).length()).is_none(),
        "the floor under the light must be unoccluded"
    );
    let to_light = light_pos - p;
    let cos = to_light.normalize().y;
    let albedo = scene.materials[tris[tri].material as usize].albedo;
    let expected = intensity * cos / to_light.length_squared() * albedo / std::f32::consts::PI;
    let got = Vec3::from(out.radiance_at(px, py));
    for c in 0..3 {
        let rel = (got[c] - expected[c]).abs() / expected[c];
        assert!(
            rel < 0.02,
            "channel {c}: rendered {} vs analytic {} ({:.2}% off) at pixel ({px},{py}), point {p}",
            got[c],
            expected[c],
            rel * 100.0
        );
    }
}

/// In the classic view, a floor pixel whose whole neighbourhood sees floor points blocked
/// from the light (CPU ray cast against the scene's triangles) receives no direct light,
/// while the image does have lit floor; no NaN/Inf.
#[test]
fn cornell_shadowed_floor_receives_no_direct_light() {
    let ctx = context();
    let (out, scene) = render(&ctx, cornell(&[]));
    assert!(out.radiance.iter().all(|v| v.is_finite()), "non-finite radiance");
    let (light_pos, _) = point_light(&scene);
    let tris = triangles(&scene, 0.0);
    // Some(true) = floor in shadow, Some(false) = lit floor, None = not floor.
    let floor_shadowed = |x: u32, y: u32| -> Option<bool> {
        let (o, d) = camera_ray(&scene, x, y);
        match raycast(&tris, o, d, 1e-4, 1e4) {
            Some((t, i)) if is_floor(&tris[i]) => {
                let q = o + d * t;
                let l = light_pos - q;
                Some(raycast(&tris, q + Vec3::Y * 1e-4, l.normalize(), 1e-4, l.length()).is_some())
            }
            _ => None,
        }
    };
    let n: u32 = SIZE.parse().unwrap();
    let r = 3;
    let mut shadowed = Vec::new();
    let mut lit = Vec::new();
    for y in (n / 2..n - r).step_by(2) {
        for x in (r..n - r).step_by(2) {
            match floor_shadowed(x, y) {
                Some(true)
                    if (0..=2 * r).all(|j| (0..=2 * r).all(|i| floor_shadowed(x + i - r, y + j - r) == Some(true))) =>
                {
                    shadowed.push((x, y))
                }
                Some(false) => lit.push((x, y)),
                _ => {}
            }
        }
    }
    assert!(shadowed.len() >= 10, "the blocks cast a shadow on the visible floor");
    for &(x, y) in &shadowed {
        let v = Vec3::from(out.radiance_at(x, y));
        assert!(v.max_element() <= 1e-6, "floor pixel ({x},{y}) is in shadow but has radiance {v}");
    }
    let lit_count = lit.iter().filter(|&&(x, y)| Vec3::from(out.radiance_at(x, y)).min_element() > 0.01).count();
    assert!(lit_count * 10 >= lit.len() * 9, "{lit_count} of {} lit floor pixels are lit", lit.len());
}

/// The EXR written is the linear radiance the renderer computed, bit for bit.
#[test]
fn exr_round_trip_is_exact() {
    let ctx = context();
    let scene = load(&repo().join("scenes/cornell-box.toml"), &[("render.width", "48"), ("render.height", "32")]);
    let (out, _) = render(&ctx, scene);
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("frame.exr");
    let png = dir.path().join("frame.png");
    dvsgi::output::write_frame(&exr, &out).unwrap();
    dvsgi::output::write_frame(&png, &out).unwrap();
    let back = dvsgi::output::read_rgb_f32(&exr).unwrap();
    assert_eq!((back.width, back.height), (48, 32));
    assert_eq!(back.data, dvsgi::output::radiance_rgb(&out));
    assert!(back.data.iter().any(|&v| v > 0.0), "image is not black");
    let png_back = image::open(&png).unwrap().to_rgb8();
    assert_eq!(png_back.dimensions(), (48, 32));
    // No temporary files are left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

/// A 10 x 10 floor at y = 0 plus a small occluder quad at y = 1, seen from straight above,
/// lit by one light given as TOML.
fn floor_scene(dir: &std::path::Path, light: &str) -> dvsgi::scene::Scene {
    std::fs::write(
        dir.join("floor.obj"),
        "o floor\nv -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nvn 0 1 0\nf 1//1 4//1 3//1 2//1\n\
         o occluder\nv -1.7 1 -1.7\nv -1.3 1 -1.7\nv -1.3 1 -1.3\nv -1.7 1 -1.3\nf 5//1 8//1 7//1 6//1\n",
    )
    .unwrap();
    let toml = format!(
        "[camera]\nposition = [0, 6, 0]\ntarget = [0, 0, 0]\nup = [0, 0, -1]\nfov_y = 60\n\
         [render]\nwidth = 96\nheight = 96\n[gi]\nmode = \"none\"\n\
         [[materials]]\nname = \"grey\"\nalbedo = [0.5, 0.4, 0.3]\n\
         [[objects]]\nobj = \"floor.obj\"\nmaterial = \"grey\"\n\n{light}"
    );
    let path = dir.join("floor.toml");
    std::fs::write(&path, toml).unwrap();
    load(&path, &[])
}

const ALBEDO: Vec3 = Vec3::new(0.5, 0.4, 0.3);

fn assert_close(got: Vec3, expected: Vec3, what: &str) {
    for c in 0..3 {
        let rel = (got[c] - expected[c]).abs() / expected[c];
        assert!(
            rel < 0.02,
            "{what}: channel {c} rendered {} vs analytic {} ({:.2}% off)",
            got[c],
            expected[c],
            rel * 100.0
        );
    }
}

/// Radiance at the floor point `p` as the renderer computed it (after checking the pixel
/// really sees that floor point).
fn radiance_at_floor(out: &dvsgi::render::FrameOutput, scene: &dvsgi::scene::Scene, p: Vec3) -> (Vec3, Vec3) {
    let (x, y) = project(scene, p);
    let (o, d) = camera_ray(scene, x, y);
    let tris = triangles(scene, 0.0);
    let (t, i) = raycast(&tris, o, d, 1e-4, 1e4).expect("hit");
    assert!(is_floor(&tris[i]), "pixel for {p} does not see the floor");
    let seen = o + d * t;
    assert!((seen - p).length() < 0.1, "pixel sees {seen}, wanted {p}");
    (Vec3::from(out.radiance_at(x, y)), seen)
}

/// Directional light: radiance = E cos(theta) albedo/pi everywhere it is unshadowed, zero in
/// the occluder's shadow.
#[test]
fn directional_light_matches_analytic_radiance_and_casts_shadow() {
    let ctx = context();
    let dir = tempfile::tempdir().unwrap();
    let scene =
        floor_scene(dir.path(), "[[lights]]\ntype = \"directional\"\ndirection = [1, -2, 0]\nirradiance = [3, 3, 3]\n");
    let (out, scene) = render(&ctx, scene);
    assert!(out.radiance.iter().all(|v| v.is_finite()));
    let cos = 2.0 / 5f32.sqrt();
    let expected = Vec3::splat(3.0) * cos * ALBEDO / std::f32::consts::PI;
    for p in [Vec3::ZERO, Vec3::new(1.5, 0.0, 1.0), Vec3::new(-2.0, 0.0, 2.0)] {
        let (got, _) = radiance_at_floor(&out, &scene, p);
        assert_close(got, expected, &format!("directional at {p}"));
    }
    // The occluder (x, z in [-1.7, -1.3] at y = 1) shadows the floor 0.5 further along +x.
    let (shadowed, _) = radiance_at_floor(&out, &scene, Vec3::new(-1.0, 0.0, -1.5));
    assert!(shadowed.max_element() <= 1e-6, "shadowed floor has radiance {shadowed}");
}

/// Spot light: I cos/d^2 albedo/pi on the axis and inside the inner cone, nothing beyond the
/// outer cone.
#[test]
fn spot_light_matches_analytic_radiance_and_cone() {
    let ctx = context();
    let dir = tempfile::tempdir().unwrap();
    let scene = floor_scene(
        dir.path(),
        "[[lights]]\ntype = \"spot\"\nposition = [0.5, 2, 0.5]\ndirection = [0, -1, 0]\nintensity = [6, 6, 6]\n\
         inner_angle = 20\nouter_angle = 30\n",
    );
    let (out, scene) = render(&ctx, scene);
    assert!(out.radiance.iter().all(|v| v.is_finite()));
    let light = Vec3::new(0.5, 2.0, 0.5);
    for offset in [Vec3::ZERO, Vec3::new(2.0 * 10f32.to_radians().tan(), 0.0, 0.0)] {
        let (got, seen) = radiance_at_floor(&out, &scene, Vec3::new(0.5, 0.0, 0.5) + offset);
        let l = light - seen;
        let expected = Vec3::splat(6.0) * l.normalize().y / l.length_squared() * ALBEDO / std::f32::consts::PI;
        assert_close(got, expected, &format!("spot at {seen}"));
    }
    // 40 degrees off the axis: outside the outer cone.
    let (outside, _) = radiance_at_floor(&out, &scene, Vec3::new(0.5 + 2.0 * 40f32.to_radians().tan(), 0.0, 0.5));
    assert_eq!(outside, Vec3::ZERO);
}

/// Scene time moves dynamic objects: the dynamic test scene renders differently at t = 0 and
/// t = 1, identically at the same time.
#[test]
fn scene_time_moves_dynamic_objects() {
    let ctx = context();
    let at = |t: &str| {
        let s = load(
            &repo().join("scenes/dynamic-test.toml"),
            // With voxel GI: two renderers voxelize alike (order-independent sums), so the
            // same time gives the same bytes.
            &[("render.width", "64"), ("render.height", "64"), ("render.time", t), ("gi.voxel_resolution", "32")],
        );
        render(&ctx, s).0.radiance
    };
    let (a, b, a2) = (at("0.0"), at("1.0"), at("0.0"));
    assert_ne!(a, b, "objects did not move between t=0 and t=1");
    assert_eq!(a, a2, "the same time must give the same image");
}

/// The shadow maps are drawn only where what they are drawn from changed, and hold the same
/// bytes as a redraw. The dynamic test scene (two moving cubes in the Cornell box, a point
/// light's six views) plus a sun through the open front (cascades fitted to the camera, and a
/// whole-scene view), in the default async schedule with two frames in flight: each frame is
/// compared, image and maps, with a new renderer's first frame at the same camera and with
/// the objects placed where they are at that time, without motion (so one pass draws every
/// caster). With the moving cubes, their shadows are drawn over a copy of the static casters'
/// maps; without motion, one pass draws every caster. Direct light alone, then voxel cone tracing
/// (whose voxel light samples the maps when it relights, here every frame).
#[test]
fn shadow_maps_are_redrawn_only_when_their_inputs_change_and_match_a_redraw() {
    use dvsgi::render::{Mode, RenderOptions, Renderer};
    use dvsgi::scene::{GiMode, Light, Motion, Scene};
    let ctx = context();
    let mut base = load(
        &repo().join("scenes/dynamic-test.toml"),
        &[("render.width", "48"), ("render.height", "48"), ("render.shadow_map_size", "128")],
    );
    base.settings.shadow_cascades = 2;
    base.settings.gi.bounces = 0;
    base.settings.gi.voxel_resolution = 16;
    let sun = LightKind::Directional { direction: Vec3::new(0.1, -0.5, 1.0), irradiance: Vec3::splat(2.0) };
    base.lights.push(Light { name: "sun".into(), kind: sun, cast_shadows: true, motion: Motion::None });
    let camera_a = base.camera.clone();
    let mut camera_b = base.camera.clone();
    camera_b.position += Vec3::new(0.05, 0.02, 0.1);
    let frames =
        [(0.5, &camera_a), (0.5, &camera_a), (1.0, &camera_a), (1.0, &camera_b), (1.5, &camera_b), (2.0, &camera_b)];
    let maps_of = |r: &mut Renderer| {
        let maps = r.all_images().into_iter().find(|i| i.name == "shadow maps").expect("shadow maps");
        r.download(&maps).unwrap()
    };
    // A redraw: a new renderer's first frame of the scene with every object placed where it
    // is at `t` without motion, so that one pass draws every caster.
    let fresh = |scene: &Scene, t: f32, camera: &dvsgi::scene::Camera| {
        let mut s = scene.clone();
        s.camera = camera.clone();
        for o in &mut s.objects {
            (o.transform, o.motion) = (o.model_matrix(t), Motion::None);
        }
        let mut r = Renderer::new(&ctx, s).unwrap();
        r.render(t, true).unwrap();
        (r.output().radiance, maps_of(&mut r))
    };
    let shadow_passes = |r: &Renderer| -> Vec<String> {
        r.last_pass_names().iter().filter(|n| n.starts_with("shadow map")).cloned().collect()
    };
    let (all, none) = (vec!["shadow maps"], Vec::<&str>::new());
    let (cached, over) = (
        vec!["shadow maps (static casters)", "shadow map copy", "shadow maps (moving casters)"],
        vec!["shadow map copy", "shadow maps (moving casters)"],
    );
    // Frame by frame, which shadow passes run. With moving casters: every view from scratch;
    // nothing; the casters moved (the static ones cached, the moving ones over the copy); the
    // camera moved (the cascades from scratch); the casters moved (the cascades cached again);
    // the casters moved (only the moving ones drawn). Without: the first frame and the
    // camera's move draw, nothing else.
    let with_motion = [&all, &none, &cached, &all, &cached, &over];
    let without = [&all, &none, &none, &all, &none, &none];
    for (moving, gi) in [(true, GiMode::None), (false, GiMode::None), (true, GiMode::Vct)] {
        let mut scene = base.clone();
        scene.settings.gi.mode = gi;
        if !moving {
            scene.objects.iter_mut().for_each(|o| o.motion = Motion::None);
        }
        let expected = if moving { with_motion } else { without };
        let options = RenderOptions { mode: Mode::Async, frames_in_flight: 2 };
        let mut r = Renderer::with_options(&ctx, scene.clone(), options).unwrap();
        for (i, (t, camera)) in frames.iter().enumerate() {
            r.scene.camera = (*camera).clone();
            r.render(*t, true).unwrap();
            let what = format!("{gi:?}, moving casters {moving}, frame {i}");
            assert_eq!(shadow_passes(&r), *expected[i], "{what}: {:?}", r.last_pass_names());
            let (image, maps) = (r.output().radiance, maps_of(&mut r));
            let (redrawn_image, redrawn_maps) = fresh(&scene, *t, camera);
            assert!(maps == redrawn_maps, "{what}: the maps differ from a redraw");
            assert!(image == redrawn_image, "{what}: the image differs from a redraw");
        }
    }
    assert_no_validation_messages(&ctx);
}

/// `render.exposure = "auto"` runs on the GPU (glsl/exposure.comp): its EV is the host's
/// (metrics::auto_exposure of the read-back radiance, f64) within float error, the display
/// image is the host's display transform at that EV to within one code in a thousandth of the
/// values, and the passes run only with "auto". In the window (eased) a light four times as
/// strong moves the shown EV part of the way at once, then all the way (-2 EV).
#[test]
fn automatic_exposure_runs_on_the_gpu_and_eases_in_the_window() {
    let ctx = context();
    let scene = cornell(&[("gi.mode", "\"none\""), ("render.exposure", "\"auto\"")]);
    let (t, settings) = (scene.settings.time, scene.settings.clone());
    let mut r = dvsgi::render::Renderer::new(&ctx, scene).expect("renderer");
    r.render(t, true).expect("frame");
    assert!(r.last_pass_names().iter().any(|p| p == "exposure"), "{:?}", r.last_pass_names());
    let out = r.output();
    let linear =
        dvsgi::metrics::LinearImage { width: out.width, height: out.height, rgb: dvsgi::output::radiance_rgb(&out) };
    let (gpu, host) = (r.auto_exposure().expect("an EV"), dvsgi::metrics::auto_exposure(&linear));
    println!("auto exposure: GPU {gpu} EV, host {host} EV");
    assert!((gpu - host).abs() < 1e-4, "GPU {gpu} against host {host}");
    let twin = dvsgi::metrics::display_srgb8(&linear, settings.exposure + host, settings.tonemap);
    let shown: Vec<u8> = out.display.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    let off: Vec<u8> = shown.iter().zip(&twin).map(|(a, b)| a.abs_diff(*b)).filter(|d| *d > 0).collect();
    println!("display against the host's twin: {} of {} values differ", off.len(), shown.len());
    // Where the differing values sit between two codes on the host (tenths of a code): near
    // 0.5 is a rounding boundary (shader arithmetic); spread out is a different conversion.
    let unrounded = dvsgi::metrics::display_unrounded(&linear, settings.exposure + host, settings.tonemap);
    let mut bins = [0usize; 10];
    for ((a, b), u) in shown.iter().zip(&twin).zip(&unrounded) {
        if a != b {
            bins[((u.fract() * 10.0) as usize).min(9)] += 1;
        }
    }
    println!("differing values by the host's fraction of a code (tenths): {bins:?}");
    assert!(off.iter().all(|d| *d <= 1) && off.len() * 1000 <= shown.len(), "{} values differ", off.len());

    // (Frames read back: their host-read barrier makes the EV visible to the host.)
    // Eased: the first frame takes its EV at once; a light 4x as strong moves it by less than
    // half of -2 EV in the next frame (rendered at once), and all the way given time.
    r.ease_exposure(Some(0.5));
    r.render(t, true).expect("frame");
    r.wait_idle().expect("idle");
    let before = r.auto_exposure().unwrap();
    for l in &mut r.scene.lights {
        if let LightKind::Point { intensity, .. } = &mut l.kind {
            *intensity *= 4.0;
        }
    }
    r.render(t, true).expect("frame");
    r.wait_idle().expect("idle");
    let next = r.auto_exposure().unwrap();
    std::thread::sleep(std::time::Duration::from_secs(3));
    r.render(t, true).expect("frame");
    r.wait_idle().expect("idle");
    let settled = r.auto_exposure().unwrap();
    println!("eased: {before} -> {next} -> {settled} EV");
    assert!(next < before && next > before - 1.0, "{before} -> {next}");
    assert!((settled - (before - 2.0)).abs() < 0.02, "{before} -> {settled}");

    r.scene.settings.exposure_auto = false;
    r.render(t, false).expect("frame");
    assert!(!r.last_pass_names().iter().any(|p| p.starts_with("exposure")));
    assert_eq!(r.auto_exposure(), None);
    drop(r);
    assert_no_validation_messages(&ctx);
}

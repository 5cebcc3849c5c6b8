//! The sky (`[sky]`, issue 44): the path tracer against analytic answers (a white furnace, a
//! plane under an image sky), the renderer's background and cones against both, scene-file
//! errors, and the leak tests (a sealed room against the same room with its roof open). On
//! lavapipe with validation on.

mod common;

use common::{context, dvsgi, load, render, repo, stderr};
use dvsgi::reference::{ReferenceImage, ReferenceOptions};
use dvsgi::scene::{LoadOptions, Scene, SceneError};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

fn trace(scene: &Scene, spp: u32, seed: u32, jitter: bool) -> ReferenceImage {
    common::trace_reference(scene, ReferenceOptions { spp, seed, jitter, batch_ms: 200.0, ..Default::default() })
}

/// An equirectangular RGB EXR of `w` x `h` texels.
fn write_exr(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) {
    let img = image::Rgb32FImage::from_fn(w, h, |x, y| image::Rgb(f(x, y)));
    image::DynamicImage::ImageRgb32F(img).save(path).unwrap();
}

/// A scene file in `dir`: `body` after a camera and a render size.
fn scene_file(dir: &Path, name: &str, camera: &str, size: u32, body: &str) -> PathBuf {
    let text = format!("[camera]\n{camera}\n\n[render]\nwidth = {size}\nheight = {size}\n\n{body}");
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// A 2 m square facing +y at y = 0 (`plane.obj` in `dir`).
fn write_plane(dir: &Path) {
    std::fs::write(dir.join("plane.obj"), "v -1 0 -1\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nf 1 2 3 4\n").unwrap();
}

/// Looking straight down at the plane from 1.5 m: every pixel sees it.
const ABOVE_THE_PLANE: &str = "position = [0.0, 1.5, 0.0]\ntarget = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov_y = 30";

fn matte_plane(sky: &str) -> String {
    format!("[[materials]]\nname = \"matte\"\nalbedo = [0.6, 0.6, 0.6]\n\n[[objects]]\nobj = \"plane.obj\"\nmaterial = \"matte\"\n\n[sky]\n{sky}\n")
}

/// The mean and its standard error over every pixel, per channel.
fn image_mean(image: &ReferenceImage) -> ([f64; 3], [f64; 3]) {
    let n = (image.width * image.height) as usize;
    let mut mean = [0.0; 3];
    let mut se = [0.0; 3];
    for c in 0..3 {
        mean[c] = (0..n).map(|i| image.mean[i * 3 + c] as f64).sum::<f64>() / n as f64;
        se[c] = (0..n).map(|i| image.variance[i * 3 + c] as f64).sum::<f64>().sqrt() / n as f64;
    }
    (mean, se)
}

#[test]
fn a_white_furnace_returns_albedo_times_the_sky_and_interreflection_keeps_it() {
    let dir = tempfile::tempdir().unwrap();
    let cube = repo().join("scenes/cube/cube.obj");
    // A convex cube of albedo 0.5 under a uniform sky of radiance 2: every point sees the sky
    // over its whole hemisphere, so it leaves with 0.5 x 2 = 1; the background is the sky.
    let body = format!(
        "[[materials]]\nname = \"grey\"\nalbedo = [0.5, 0.5, 0.5]\n\n[[objects]]\nobj = {cube:?}\nmaterial = \"grey\"\n\n\
         [sky]\ntype = \"constant\"\nradiance = [1.0, 1.0, 1.0]\nscale = 2.0\n"
    );
    let camera = "position = [2.0, 1.5, 3.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 40";
    let scene = load(&scene_file(dir.path(), "cube.toml", camera, 32, &body), &[]);
    let image = trace(&scene, 64, 1, false);
    let n = (image.width * image.height) as usize;
    let (mut cube_pixels, mut sum, mut var) = (0, 0.0, 0.0);
    for i in 0..n {
        let (m, v) = (image.mean[i * 3] as f64, image.variance[i * 3] as f64);
        if v == 0.0 && m == 2.0 {
            continue; // the sky, exactly
        }
        cube_pixels += 1;
        sum += m;
        var += v;
        assert!((m - 1.0).abs() < 5.0 * v.sqrt() + 1e-4, "cube pixel {i}: {m} (sigma {})", v.sqrt());
    }
    assert!(cube_pixels > 100, "{cube_pixels} cube pixels");
    let (mean, se) = (sum / cube_pixels as f64, var.sqrt() / cube_pixels as f64);
    println!("convex furnace: {mean:.5} (standard error {se:.5}) over {cube_pixels} pixels, analytic 1");
    assert!((mean - 1.0).abs() < 3.0 * se + 1e-4, "{mean} vs 1 (standard error {se})");

    // The renderer's cones see the same sky past the cube (no light but the sky).
    let (out, _) = render(&context(), scene);
    let (mut r_sum, mut r_n) = (0.0, 0);
    for i in 0..n {
        if image.variance[i * 3] > 0.0 {
            r_sum += out.radiance[i * 4] as f64;
            r_n += 1;
        }
    }
    let r_mean = r_sum / r_n as f64;
    println!("renderer: {r_mean:.4} of the analytic 1");
    assert!((r_mean - 1.0).abs() < 0.03, "renderer's convex furnace {r_mean}");

    // Albedo 1 everywhere, in an open box (McGuire's Cornell box geometry, all of it white):
    // every direction sees either the sky or a surface that leaves with the sky's radiance,
    // so every pixel is the sky's radiance, interreflection and all.
    let body = format!(
        "[[materials]]\nname = \"white\"\nalbedo = [1.0, 1.0, 1.0]\n\n[[objects]]\nobj = {:?}\nmaterial = \"white\"\n\n\
         [sky]\ntype = \"constant\"\nradiance = [0.5, 0.5, 0.5]\n",
        repo().join("scenes/cornell-box/cornell-box.obj")
    );
    let camera = "position = [0.278, 0.273, -0.5]\ntarget = [0.278, 0.273, 0.0]\nfov_y = 60";
    let scene = load(&scene_file(dir.path(), "box.toml", camera, 16, &body), &[]);
    let image = trace(&scene, 128, 2, false);
    let (mean, se) = image_mean(&image);
    println!("open white box: {:.5} (standard error {:.5}), analytic 0.5", mean[0], se[0]);
    assert!(se[0] > 0.0 && se[0] < 0.01, "too noisy to judge: {}", se[0]);
    assert!((mean[0] - 0.5).abs() < 3.0 * se[0] + 1e-4, "{} vs 0.5 (standard error {})", mean[0], se[0]);
}

/// What a horizontal plane of albedo `rho` under `sky` (its texels as the path tracer reads
/// them, nearest) sends up: rho / pi times the irradiance, the sum over the upper hemisphere's
/// texels of L times the integral of cos(theta) over the texel.
fn plane_radiance(rho: f64, w: u32, h: u32, texel: impl Fn(u32, u32) -> [f32; 3]) -> [f64; 3] {
    let mut e = [0.0; 3];
    let dphi = 2.0 * PI / w as f64;
    for y in 0..h / 2 {
        let (t0, t1) = (PI * y as f64 / h as f64, PI * (y + 1) as f64 / h as f64);
        let weight = dphi * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
        for x in 0..w {
            let l = texel(x, y);
            for c in 0..3 {
                e[c] += l[c] as f64 * weight;
            }
        }
    }
    e.map(|v| rho / PI * v)
}

/// A sky with a gradient in both directions and a small, very bright sun (two texels of
/// 11 x 11 degrees with 600 times the rest): the image must be importance-sampled to converge.
fn sun_sky(x: u32, y: u32) -> [f32; 3] {
    if y == 3 && (x == 5 || x == 6) {
        return [200.0, 180.0, 150.0];
    }
    [0.2 + 0.05 * x as f32 / 32.0, 0.3, 0.5 * (1.0 - y as f32 / 16.0)]
}

#[test]
fn an_image_sky_lights_a_plane_as_its_integral_says_and_converges_at_one_over_root_spp() {
    let dir = tempfile::tempdir().unwrap();
    write_plane(dir.path());
    write_exr(&dir.path().join("sky.exr"), 32, 16, sun_sky);
    // Turned (a horizontal plane's light does not depend on it) and scaled by 0.5.
    let sky = "type = \"image\"\nimage = \"sky.exr\"\nrotation = 30.0\nscale = 0.5";
    let scene = load(&scene_file(dir.path(), "plane.toml", ABOVE_THE_PLANE, 24, &matte_plane(sky)), &[]);
    let exact = plane_radiance(0.6, 32, 16, sun_sky).map(|v| v * 0.5);
    let image = trace(&scene, 256, 1, true);
    let (mean, se) = image_mean(&image);
    for c in 0..3 {
        println!("channel {c}: {:.5} (standard error {:.5}), analytic {:.5}", mean[c], se[c], exact[c]);
        assert!(se[c] < 0.01 * exact[c], "too noisy to judge: {}", se[c]);
        assert!((mean[c] - exact[c]).abs() < 4.0 * se[c] + 1e-5, "channel {c}: {} vs {}", mean[c], exact[c]);
    }
    // The error falls as 1 / sqrt(spp), and the variance image predicts it.
    let mut points = Vec::new();
    for (k, spp) in [4u32, 16, 64].into_iter().enumerate() {
        let image = trace(&scene, spp, 10 + k as u32, true);
        let n = image.mean.len();
        let mse = (0..n).map(|i| (image.mean[i] as f64 - exact[i % 3]).powi(2)).sum::<f64>() / n as f64;
        let predicted = image.variance.iter().map(|&v| v as f64).sum::<f64>() / n as f64;
        println!("{spp:>3} spp: RMSE {:.5}, predicted {:.5}", mse.sqrt(), predicted.sqrt());
        assert!((0.6..1.6).contains(&(mse / predicted)), "variance off: mse {mse}, predicted {predicted}");
        points.push(((spp as f64).ln(), mse.sqrt().ln()));
    }
    let slope = common::slope(&points);
    println!("slope {slope:.3}");
    assert!((slope + 0.5).abs() < 0.1, "log RMSE / log spp slope {slope}, expected -0.5");

    // The renderer: diffuse cones that leave the grid see the sky prefiltered to their aperture,
    // scaled to the sky's exact irradiance (without that, the sun fell between cones: 0.82).
    let (out, _) = render(&context(), scene);
    let n = (out.width * out.height) as usize;
    for (c, e) in exact.iter().enumerate() {
        let r = (0..n).map(|i| out.radiance[i * 4 + c] as f64).sum::<f64>() / n as f64;
        println!("renderer channel {c}: {r:.5}, {:.3} of the analytic", r / e);
        assert!((r / e - 1.0).abs() < 0.03, "renderer channel {c}: {r} vs {e}");
    }
}

#[test]
fn a_gradient_sky_lights_a_plane_as_the_formula_says() {
    let dir = tempfile::tempdir().unwrap();
    write_plane(dir.path());
    let sky = "type = \"gradient\"\nzenith = [0.2, 0.4, 1.0]\nhorizon = [0.9, 0.8, 0.7]\nground = [0.1, 0.1, 0.1]";
    let scene = load(&scene_file(dir.path(), "plane.toml", ABOVE_THE_PLANE, 16, &matte_plane(sky)), &[]);
    // E = pi h + (z - h) 2 pi / 3 over the upper hemisphere of an upward plane.
    let (z, h) = ([0.2, 0.4, 1.0], [0.9, 0.8, 0.7]);
    let exact: [f64; 3] = std::array::from_fn(|c| 0.6 / PI * (PI * h[c] + (z[c] - h[c]) * 2.0 * PI / 3.0));
    let image = trace(&scene, 64, 3, true);
    let (mean, se) = image_mean(&image);
    let (out, _) = render(&context(), scene);
    let n = (out.width * out.height) as usize;
    for c in 0..3 {
        let r = (0..n).map(|i| out.radiance[i * 4 + c] as f64).sum::<f64>() / n as f64;
        println!("channel {c}: traced {:.5} (se {:.5}), rendered {r:.5}, analytic {:.5}", mean[c], se[c], exact[c]);
        // The map holds each band's exact mean; the texels' cosine weights are exact per band.
        assert!((mean[c] - exact[c]).abs() < 4.0 * se[c] + 2e-3 * exact[c], "traced channel {c}");
        assert!((r / exact[c] - 1.0).abs() < 0.02, "rendered channel {c}: {r} vs {}", exact[c]);
    }
}

#[test]
fn the_background_is_the_sky_turned_as_the_scene_says() {
    let dir = tempfile::tempdir().unwrap();
    // Sixteen columns of distinct colours; rows alike.
    let colour = |x: u32| [x as f32 + 1.0, 0.5, 16.0 - x as f32];
    write_exr(&dir.path().join("sky.exr"), 16, 8, |x, _| colour(x));
    let cube = repo().join("scenes/cube/cube.obj");
    // Looking 11.25 degrees from -z towards +x, at the centre of column 8; a cube behind.
    let (s, c) = (11.25f64.to_radians().sin(), 11.25f64.to_radians().cos());
    let camera = format!("position = [0.0, 0.0, 0.0]\ntarget = [{s}, 0.0, {}]\nfov_y = 2", -c);
    for (rotation, column) in [(0.0, 8), (90.0, 12), (-90.0, 4)] {
        let body = format!(
            "[[objects]]\nobj = {cube:?}\ntranslate = [0.0, 0.0, 5.0]\n\n[sky]\ntype = \"image\"\nimage = \"sky.exr\"\nrotation = {rotation}\n"
        );
        let scene = load(&scene_file(dir.path(), "bg.toml", &camera, 8, &body), &[]);
        let want = colour(column);
        let traced = trace(&scene, 1, 1, false);
        let (out, _) = render(&context(), scene);
        for i in 0..64usize {
            for (ch, w) in want.iter().enumerate() {
                let t = traced.mean[i * 3 + ch];
                assert_eq!(t, *w, "rotation {rotation}: traced pixel {i} channel {ch}");
                let r = out.radiance[i * 4 + ch];
                assert!((r - w).abs() < 0.1 * w.max(1.0), "rotation {rotation}: rendered {r} vs {w}");
            }
        }
    }
}

fn load_error(dir: &Path, body: &str) -> SceneError {
    let camera = "position = [0.0, 1.0, 3.0]\ntarget = [0.0, 0.0, 0.0]";
    let path = scene_file(dir, "bad.toml", camera, 8, body);
    dvsgi::scene::load(&path, &LoadOptions::default()).expect_err("must not load")
}

#[test]
fn bad_skies_are_refused_with_the_file_and_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let check = |body: &str, words: &[&str]| {
        let m = load_error(d, body).to_string();
        for w in words {
            assert!(m.contains(w), "{m:?} lacks {w:?}");
        }
    };
    check("[sky]\ntype = \"sunny\"\n", &["bad.toml", "sky.type", "constant, gradient, image, none"]);
    check("[sky]\ntype = \"constant\"\n", &["sky.radiance", "needs"]);
    check("[sky]\ntype = \"constant\"\nradiance = [1, 1, 1]\nzenith = [1, 1, 1]\n", &["sky.zenith", "does not apply"]);
    check("[sky]\ntype = \"constant\"\nradiance = [1, -1, 1]\n", &["sky.radiance", ">= 0"]);
    check("[sky]\ntype = \"constant\"\nradiance = [1, 1, 1]\nscale = -2\n", &["sky.scale", ">= 0"]);
    check("[sky]\ntype = \"gradient\"\nzenith = [1, 1, 1]\nhorizon = [1, 1, 1]\n", &["sky.ground"]);
    check("[sky]\ntype = \"image\"\nimage = \"nowhere.exr\"\n", &["nowhere.exr", "bad.toml"]);
    check("[sky]\ntype = \"image\"\n", &["sky.image", "needs"]);
    check("[sky]\nkind = \"constant\"\n", &["bad.toml", "kind"]);
    // A PNG holds display values, not radiance.
    image::RgbImage::from_pixel(8, 4, image::Rgb([9, 9, 9])).save(d.join("sky.png")).unwrap();
    check("[sky]\ntype = \"image\"\nimage = \"sky.png\"\n", &["sky.png", "OpenEXR", "convert"]);
    // Not twice as wide as high.
    write_exr(&d.join("square.exr"), 8, 8, |_, _| [1.0; 3]);
    check("[sky]\ntype = \"image\"\nimage = \"square.exr\"\n", &["square.exr", "8x8", "twice as wide"]);
    write_exr(&d.join("nan.exr"), 8, 4, |x, y| if (x, y) == (3, 2) { [f32::NAN, 0.0, 0.0] } else { [1.0; 3] });
    check("[sky]\ntype = \"image\"\nimage = \"nan.exr\"\n", &["nan.exr", "(3, 2)", "finite"]);
    std::fs::write(d.join("junk.exr"), b"v/1\x01 not an exr").unwrap();
    check("[sky]\ntype = \"image\"\nimage = \"junk.exr\"\n", &["junk.exr", "sky"]);
    // `type = "none"` turns a sky off whatever else the table says (one --set does it).
    let camera = "position = [0.0, 1.0, 3.0]\ntarget = [0.0, 0.0, 0.0]";
    let path = scene_file(
        d,
        "off.toml",
        camera,
        8,
        "[sky]\ntype = \"gradient\"\nzenith = [1, 1, 1]\nhorizon = [1, 1, 1]\nground = [0, 0, 0]\n",
    );
    assert!(load(&path, &[("sky.type", "none")]).sky.is_none());
    assert!(load(&path, &[]).sky.is_some());
    // And a scene without a sky takes one from --set.
    let path = scene_file(d, "plain.toml", camera, 8, "");
    let s = load(&path, &[("sky.type", "constant"), ("sky.radiance", "[0.5, 0.5, 0.5]")]);
    assert!(s.sky.is_some_and(|s| s.mean_radiance() == 0.5));
    // The command line: a non-zero exit, the file named, no output written.
    let out = d.join("never.png");
    let o = dvsgi(&["render", d.join("bad.toml").to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(!o.status.success() && stderr(&o).contains("junk.exr"), "{}", stderr(&o));
    assert!(!out.exists());
}

/// Mean radiance of a rendered view of `scene` with `overrides`.
fn mean_radiance(path: &Path, overrides: &[(&str, &str)]) -> f64 {
    let (out, _) = render(&context(), load(path, overrides));
    let n = (out.width * out.height) as usize;
    (0..n).map(|i| (out.radiance[i * 4] + out.radiance[i * 4 + 1] + out.radiance[i * 4 + 2]) as f64 / 3.0).sum::<f64>()
        / n as f64
}

#[test]
fn a_sealed_room_keeps_the_sky_and_the_sun_out() {
    // scenes/leak: a 4 x 3 x 4 m room under a sun and a sky, walls two voxels thick at 128^3;
    // seen from inside at 32x32. The path tracer finds nothing inside the sealed room.
    let leak = repo().join("scenes/leak");
    let size = [("render.width", "32"), ("render.height", "32")];
    let with = |op: &'static str, cover: &'static str| {
        let mut o = size.to_vec();
        o.push(("gi.opacity", op));
        o.push(("gi.voxel_cover", cover));
        o
    };
    let open = mean_radiance(&leak.join("open-room-t2.toml"), &with("layers", "\"touch\""));
    let sealed = mean_radiance(&leak.join("sealed-room-t2.toml"), &with("layers", "\"touch\""));
    let blend = mean_radiance(&leak.join("sealed-room-t2.toml"), &with("blend", "\"touch\""));
    let open_blend = mean_radiance(&leak.join("open-room-t2.toml"), &with("blend", "\"touch\""));
    let open_dir = mean_radiance(&leak.join("open-room-t2.toml"), &with("layers", "\"directional\""));
    let sealed_dir = mean_radiance(&leak.join("sealed-room-t2.toml"), &with("layers", "\"directional\""));
    let quarters = |room: &str| {
        let mut o = with("layers", "\"directional\"");
        o.push(("gi.footprint", "\"quadrants\""));
        o.push(("gi.bounce_footprint", "\"quadrants\""));
        mean_radiance(&leak.join(room), &o)
    };
    let (open_q, sealed_q) = (quarters("open-room-t2.toml"), quarters("sealed-room-t2.toml"));
    println!(
        "sealed / open: layers {:.4} ({sealed:.4} / {open:.4}), blend {:.4} ({blend:.4} / {open_blend:.4}), \
         layers with directional cover {:.4} ({sealed_dir:.4} / {open_dir:.4}), and quadrant footprints {:.4} \
         ({sealed_q:.4} / {open_q:.4})",
        sealed / open,
        blend / open_blend,
        sealed_dir / open_dir,
        sealed_q / open_q
    );
    assert!(open > 0.1 && open_dir > 0.1, "the open room is lit: {open}, {open_dir}");
    // Issue 44's target is at most 2% of the open room's light for walls of two voxels; not
    // met (ACCURACY.md, "Sky light and leaks": the cones alone let 2% of the sky through,
    // the bounce adds the outer walls' light). This holds what was measured, 0.054 at 64x64.
    assert!(sealed / open <= 0.07, "gi.opacity = layers: the sealed room gets {:.4} of the open one", sealed / open);
    // With gi.voxel_cover = "directional" the walls' outer voxels, seen edge-on from inside
    // through a coarse texel, are open and dark as the walls' faces are: 0.022 at 64x64.
    let dir = sealed_dir / open_dir;
    assert!(dir <= 0.03 && dir < 0.6 * sealed / open, "layers, directional cover: {dir:.4} of the open room");
    // With quadrant footprints as well (the pixels' and the bounce's), a side wall and the roof
    // that cover different quarters of a cone's footprint leave none of it open: issue 44's 2%
    // (0.017 at 64x64; 0.0215 with the pixels' quadrants alone).
    assert!(open_q > 0.1, "the open room is lit with quadrants: {open_q}");
    let q = sealed_q / open_q;
    assert!(q <= 0.02 && q < 0.85 * dir, "layers, directional cover, quadrants: {q:.4} of the open room");
    // The default leaks, as ACCURACY.md says (0.21 at 64x64): not more than that.
    assert!(blend / open_blend <= 0.25, "gi.opacity = blend: {:.4} of the open room", blend / open_blend);
}

/// `gi.plane_backs = "dark"` (ACCURACY.md, "Planes dark from behind"): a room sealed by walls
/// four voxels thick, with `layers`, directional cover and the pixels' quadrants, let in more
/// than one with thinner walls (0.026 of its open-roofed twin's light at 64x64, against 0.020
/// for one voxel): the walls' sunlit outer voxels, whose light every side saw, shone in through
/// texels that hold both of a wall's faces. Shown their emission only from behind, they do not
/// (0.015 at 64x64; here, at 32x32, 0.0224 lit and 0.0132 dark on lavapipe).
#[test]
fn dark_plane_backs_keep_a_thick_wall_s_sunlit_outside_out() {
    let leak = repo().join("scenes/leak");
    let settings = |backs: &'static str| {
        vec![
            ("render.width", "32"),
            ("render.height", "32"),
            ("gi.opacity", "\"layers\""),
            ("gi.voxel_cover", "\"directional\""),
            ("gi.footprint", "\"quadrants\""),
            ("gi.plane_backs", backs),
        ]
    };
    let ratio = |backs| {
        let open = mean_radiance(&leak.join("open-room-t4.toml"), &settings(backs));
        assert!(open > 0.1, "the open room is lit: {open}");
        mean_radiance(&leak.join("sealed-room-t4.toml"), &settings(backs)) / open
    };
    let (lit, dark, closed) = (ratio("\"lit\""), ratio("\"dark\""), ratio("\"closed\""));
    println!("sealed / open, walls of 4 voxels: lit backs {lit:.4}, dark backs {dark:.4}, closed {closed:.4}");
    assert!(dark <= 0.02 && dark < 0.8 * lit, "walls of 4 voxels: dark backs {dark:.4}, lit {lit:.4}");
    // A wall's outer face, seen from inside, is the back of a closed slab: left out, it lets
    // nothing more in (the slab's inner face, met first, is still there).
    assert!(closed <= 0.02, "walls of 4 voxels: closed backs {closed:.4}");
}

/// Issue 44's window room (`scenes/leak/window-room.toml`, walls of 2 voxels at 128^3): with
/// the settings that keep the sealed room's light out (`"layers"`, directional cover, both
/// footprints in quadrants) and `gi.plane_backs = "closed"`, every wall's indirect light is
/// within 20% of the path tracer's, after 8 frames (48x48, lavapipe: roof 0.89, window wall
/// 1.01, wall -z 0.91, floor 0.81; with `"dark"` the floor gets 0.78: its slabs' outer faces,
/// seen from inside through texels that hold both faces, blocked the cones a second time).
#[test]
fn the_window_room_is_lit_within_a_fifth_of_the_path_tracer_wall_by_wall() {
    use dvsgi::regions::{region_stats, Grouping, Pair, RegionMap};
    use dvsgi::render::Renderer;
    let ctx = context();
    let path = repo().join("scenes/leak/window-room.toml");
    let settings = [
        ("render.width", "48"),
        ("render.height", "48"),
        ("gi.opacity", "\"layers\""),
        ("gi.voxel_cover", "\"directional\""),
        ("gi.footprint", "\"quadrants\""),
        ("gi.bounce_footprint", "\"quadrants\""),
        ("gi.plane_backs", "\"closed\""),
    ];
    // The reference's indirect light: its image less the sun's direct light (the renderer's
    // indirect view holds the sky's light, which is indirect to it).
    let scene = load(&path, &settings);
    let full = trace(&scene, 1024, 1, false);
    let sun_only = load(&path, &[&settings[..], &[("sky.type", "\"none\"")]].concat());
    let direct = common::trace_reference(
        &sun_only,
        ReferenceOptions { spp: 64, max_bounces: Some(0), batch_ms: 200.0, ..Default::default() },
    );
    let truth = dvsgi::metrics::LinearImage {
        width: full.width,
        height: full.height,
        rgb: full.mean.iter().zip(&direct.mean).map(|(a, b)| a - b).collect(),
    };
    let mut r =
        Renderer::new(&ctx, load(&path, &[&settings[..], &[("render.view", "\"indirect\"")]].concat())).unwrap();
    for frame in 0..8 {
        r.render(0.0, frame == 7).unwrap();
    }
    let out = r.output();
    drop(r);
    common::assert_no_validation_messages(&ctx);
    let test =
        dvsgi::metrics::LinearImage { width: out.width, height: out.height, rgb: dvsgi::output::radiance_rgb(&out) };
    let map = RegionMap::trace(&scene, 48, 48);
    let walls = region_stats(&map, &Pair { test: &test, reference: &truth, reference_variance: None });
    let walls: Vec<_> = walls.iter().filter(|s| s.grouping == Grouping::Mesh && !s.small).collect();
    let report: Vec<String> = walls.iter().map(|s| format!("{} {:.3}", s.name, s.ratio)).collect();
    println!("window room, indirect light / the path tracer's: {}", report.join("; "));
    assert_eq!(walls.len(), 4, "the roof, the floor and two walls in view: {report:?}");
    for s in walls {
        assert!((0.8..=1.2).contains(&s.ratio), "{}: {:.3} of the path tracer's indirect light", s.name, s.ratio);
    }
}

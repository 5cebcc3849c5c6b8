//! `dvsgi reference`, `compare` and `sweep` end to end on lavapipe with validation on:
//! a miniature sweep (three configurations, a tiny image) producing a valid CSV, JSON and
//! frontier pictures, resuming without redoing rows, and refusing a changed setup; the
//! compare command's figures against hand-computed values; bad input failing cleanly.

mod common;

use common::{dvsgi, repo};
use dvsgi::metrics::{auto_exposure, compare, LinearImage};
use dvsgi::sweep::{Results, Row};
use std::path::Path;
use std::process::Output;

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn ok(o: &Output) -> String {
    let t = text(o);
    assert!(o.status.success(), "failed:\n{t}");
    t
}

fn fails(o: &Output, code: i32) -> String {
    let t = text(o);
    assert_eq!(o.status.code(), Some(code), "exit code:\n{t}");
    assert!(!t.contains("panicked"), "panic:\n{t}");
    t
}

fn sweep(out: &Path, grid: &[&str], spp: &str) -> Output {
    let mut args = vec![
        "sweep",
        "scenes/cornell-box.toml",
        "--out",
        out.to_str().unwrap(),
        "--width",
        "24",
        "--height",
        "24",
        "--spp",
        spp,
        "--frames",
        "1",
        "--warmup",
        "0",
        "--grid",
        "voxel_resolution=16",
    ];
    for g in grid {
        args.extend(["--grid", g]);
    }
    dvsgi(&args)
}

#[test]
fn miniature_sweep_writes_rows_fronts_and_pictures_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sweep");
    ok(&sweep(&out, &["bounces=0,1"], "16"));
    let rows: Vec<Row> =
        csv::Reader::from_path(out.join("results.csv")).unwrap().deserialize().map(|r| r.unwrap()).collect();
    assert_eq!(rows.iter().map(|r| r.label.as_str()).collect::<Vec<_>>(), ["v16 b0", "v16 b1"]);
    for r in &rows {
        assert_eq!(r.voxel_resolution, 16);
        assert!(r.frame_ms > 0.0 && r.static_frame_ms > 0.0 && r.gpu_mib > 0.0, "{r:?}");
        assert!(r.rmse.is_finite() && r.rmse > 0.0 && r.flip_mean > 0.0 && r.ssim_mean < 1.0, "{r:?}");
    }
    // Each metric has a front, and the fastest row is always on it.
    let fastest = rows.iter().min_by(|a, b| a.frame_ms.total_cmp(&b.frame_ms)).unwrap();
    for (m, _) in dvsgi::sweep::METRICS {
        assert!(fastest.on_front(m), "{m}: the fastest configuration is never dominated");
        let svg = std::fs::read_to_string(out.join(format!("frontier-{m}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{m}");
        assert!(svg.contains(&fastest.label), "{m}: front label missing");
    }
    let results: Results = serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(results.rows.len(), rows.len());
    for (j, c) in results.rows.iter().zip(&rows) {
        assert_eq!(j.label, c.label);
        assert!((j.frame_ms - c.frame_ms).abs() < 1e-6 && (j.rmse - c.rmse).abs() < 1e-9);
    }
    assert_eq!(results.setup.spp, 16);
    assert!(results.reference_noise_rmse > 0.0);
    for f in ["reference.exr", "reference.var.exr", "reference.json", "sweep.json"] {
        assert!(out.join(f).exists(), "{f}");
    }

    // A wider grid in the same directory reuses the reference and the finished rows.
    let t = ok(&sweep(&out, &["bounces=0,1,2"], "16"));
    assert!(t.contains("reference: cached"), "{t}");
    assert!(t.contains("resuming: 2 of 3"), "{t}");
    let again: Vec<Row> =
        csv::Reader::from_path(out.join("results.csv")).unwrap().deserialize().map(|r| r.unwrap()).collect();
    assert_eq!(again.len(), 3);
    assert!((again[0].frame_ms - rows[0].frame_ms).abs() < 1e-6, "a finished row was measured again");

    // A narrower grid keeps the rows of the earlier one: they are the user's measurements.
    let t = ok(&sweep(&out, &["bounces=1"], "16"));
    assert!(t.contains("keeping 2 rows"), "{t}");
    let kept: Vec<Row> =
        csv::Reader::from_path(out.join("results.csv")).unwrap().deserialize().map(|r| r.unwrap()).collect();
    assert_eq!(kept.iter().map(|r| r.label.as_str()).collect::<Vec<_>>(), ["v16 b1", "v16 b0", "v16 b2"]);
    let results: Results = serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(results.rows.len(), 3);

    // Another setup in the same directory is refused, naming what changed.
    let t = fails(&sweep(&out, &["bounces=0"], "32"), 1);
    assert!(t.contains("different setup") && t.contains("spp"), "{t}");
    // A bad grid fails before anything runs.
    let t = fails(&sweep(&dir.path().join("other"), &["bounces=1.5"], "16"), 1);
    assert!(t.contains("bounces") && !dir.path().join("other").exists(), "{t}: no directory is left behind");
    let t = fails(&sweep(&dir.path().join("other"), &["downsample=9"], "16"), 1);
    assert!(t.contains("downsample"), "{t}");
}

/// With `render.exposure = "auto"` a sweep shows each test image at the reference's exposure,
/// as one display of both: a row's display metrics (FLIP, SSIM) are those of its image against
/// the reference with both exposed for the reference's lit pixels. The configuration here is the
/// direct light alone against the full reference, darker everywhere, so its own automatic
/// exposure is brighter and would hide the missing light. Guards against the sweep exposing each
/// test image for itself.
#[test]
fn an_auto_exposed_sweep_shows_the_test_image_at_the_references_exposure() {
    let dir = tempfile::tempdir().unwrap();
    let (out, exr) = (dir.path().join("sweep"), dir.path().join("test.exr"));
    let size = ["--width", "24", "--height", "24", "--set", "render.exposure=\"auto\""];
    let mut args = vec!["sweep", "scenes/cornell-box.toml", "--out", out.to_str().unwrap()];
    args.extend(["--spp", "16", "--frames", "1", "--warmup", "0", "--grid", "mode=none"]);
    ok(&dvsgi(&[args.as_slice(), &size].concat()));
    let rows: Vec<Row> =
        csv::Reader::from_path(out.join("results.csv")).unwrap().deserialize().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 1);
    // The configuration's image, rendered on its own (direct light: the same every run).
    let render = ["render", "scenes/cornell-box.toml", "--gi", "none", "--out", exr.to_str().unwrap()];
    ok(&dvsgi(&[render.as_slice(), &size].concat()));
    let test = LinearImage::read_exr(&exr).unwrap();
    let reference = LinearImage::read_exr(&out.join("reference.exr")).unwrap();
    let (ev_ref, ev_own) = (auto_exposure(&reference), auto_exposure(&test));
    let scene = dvsgi::scene::load(&repo().join("scenes/cornell-box.toml"), &Default::default()).unwrap();
    let shown_at = |ev: f32| compare(&test, &reference, ev, scene.settings.tonemap).unwrap();
    let (shared, own) = (shown_at(ev_ref), shown_at(ev_own));
    let r = &rows[0];
    println!(
        "exposure: reference {ev_ref:.3}, test's own {ev_own:.3}; FLIP, SSIM: row {:.4}, {:.4}; at the reference's \
         {:.4}, {:.4}; at its own {:.4}, {:.4}",
        r.flip_mean, r.ssim_mean, shared.flip.mean, shared.ssim.mean, own.flip.mean, own.ssim.mean
    );
    assert!(ev_own > ev_ref + 0.25, "the direct light alone is darker: {ev_own} against {ev_ref}");
    // The two exposures tell the figures apart far beyond the tolerance below.
    let apart = (own.flip.mean - shared.flip.mean).abs() + (own.ssim.mean - shared.ssim.mean).abs();
    assert!(apart > 0.02, "the display metrics barely depend on the exposure: {apart}");
    assert!((r.flip_mean - shared.flip.mean).abs() < 1e-3, "FLIP {} against {}", r.flip_mean, shared.flip.mean);
    assert!((r.ssim_mean - shared.ssim.mean).abs() < 1e-3, "SSIM {} against {}", r.ssim_mean, shared.ssim.mean);
}

fn write_exr(path: &Path, w: u32, h: u32, rgb: &[f32]) {
    dvsgi::output::write_exr(path, w, h, rgb).unwrap();
}

/// `compare --scene`: per-region figures from the scene's own surfaces, for the images as
/// given and for the indirect light alone, with a picture of the signed ratio.
#[test]
fn compare_reports_error_per_region() {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = repo().join("scenes/cornell-box.toml");
    let scene = dvsgi::scene::load(&scene_path, &Default::default()).unwrap();
    let map = dvsgi::regions::RegionMap::trace(&scene, 16, 16);
    let floor: Vec<bool> = map
        .pixel
        .iter()
        .map(|&id| id != dvsgi::regions::BACKGROUND && map.surfaces[id as usize].mesh == "floor")
        .collect();
    assert!(floor.iter().filter(|&&f| f).count() >= 4, "the floor is in the 16x16 picture");
    // Reference 2 everywhere (direct light 1, indirect 1); the test has half the indirect light
    // on the floor and the right amount elsewhere.
    let (t, r, d) = (dir.path().join("t.exr"), dir.path().join("r.exr"), dir.path().join("d.exr"));
    write_exr(&r, 16, 16, &[2.0; 768]);
    write_exr(&d, 16, 16, &[1.0; 768]);
    let test: Vec<f32> = floor.iter().flat_map(|&f| [if f { 1.5 } else { 2.0 }; 3]).collect();
    write_exr(&t, 16, 16, &test);
    let (json, ratio) = (dir.path().join("c.json"), dir.path().join("ratio.png"));
    let path = |p: &Path| p.to_str().unwrap().to_string();
    let args = [
        "compare".to_string(),
        path(&t),
        path(&r),
        "--scene".into(),
        "scenes/cornell-box.toml".into(),
        "--ref-direct".into(),
        path(&d),
        "--ratio".into(),
        path(&ratio),
        "--json".into(),
        path(&json),
    ];
    let o = ok(&dvsgi(&args.iter().map(|s| s.as_str()).collect::<Vec<_>>()));
    assert!(o.contains("indirect light by region") && o.contains("box/floor +y"), "{o}");
    let j: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let find = |list: &str, grouping: &str, name: &str| {
        j[list].as_array().unwrap().iter().find(|s| s["grouping"] == grouping && s["name"] == name).unwrap()["ratio"]
            .as_f64()
            .unwrap()
    };
    assert!((find("indirect", "mesh", "box/floor") - 0.5).abs() < 1e-6);
    assert!((find("indirect", "mesh", "box/ceiling") - 1.0).abs() < 1e-6);
    assert!((find("regions", "mesh", "box/floor") - 0.75).abs() < 1e-6);
    assert!((find("regions", "material", "red") - 1.0).abs() < 1e-6);
    assert!(j["rmse"].as_f64().unwrap() > 0.0, "the whole-image figures are still there");
    let picture = image::open(&ratio).unwrap().to_rgb8();
    assert_eq!(picture.dimensions(), (16, 16));
    let i = floor.iter().position(|&f| f).unwrap() as u32;
    assert_eq!(picture.get_pixel(i % 16, i / 16).0, [0, 0, 255], "one stop too dark is saturated blue");
    // The direct light needs the scene; a direct image of another size is named.
    let t2 = fails(&dvsgi(&["compare", &path(&t), &path(&r), "--ref-direct", &path(&d)]), 2);
    assert!(t2.contains("--scene"), "{t2}");
    let small = dir.path().join("small.exr");
    write_exr(&small, 1, 1, &[1.0; 3]);
    let t3 = fails(
        &dvsgi(&["compare", &path(&t), &path(&r), "--scene", "scenes/cornell-box.toml", "--ref-direct", &path(&small)]),
        1,
    );
    assert!(t3.contains("small.exr") && t3.contains("1x1"), "{t3}");
    // Under a sky the renderer's indirect light holds the sky's: the split is named.
    assert!(!o.contains("has a sky"), "no sky, no note:\n{o}");
    let sky = ["compare", &path(&t), &path(&r), "--scene", "scenes/leak/window-room.toml", "--ref-direct", &path(&d)];
    let o = ok(&dvsgi(&sky));
    assert!(o.contains("has a sky") && o.contains("sky.type"), "{o}");
}

#[test]
fn compare_reports_hand_computed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    // Reference all 1.0; the test image has one channel of one of four pixels at 2.0:
    // MSE = 1/12, RMSE = 0.288675; relMSE = (1 / 1.01) / 12 = 0.082508.
    write_exr(&b, 2, 2, &[1.0; 12]);
    let mut t = [1.0f32; 12];
    t[4] = 2.0;
    write_exr(&a, 2, 2, &t);
    let diff = dir.path().join("diff.png");
    let json = dir.path().join("c.json");
    let o = ok(&dvsgi(&[
        "compare",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--diff",
        diff.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]));
    assert!(o.contains("RMSE   0.288675"), "{o}");
    assert!(o.contains("relMSE 0.082508"), "{o}");
    assert!(image::open(&diff).unwrap().width() == 2);
    let c: dvsgi::metrics::Comparison = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!((c.rmse - (1.0f64 / 12.0).sqrt()).abs() < 1e-9);
    assert!(c.flip.mean > 0.0 && c.ssim.mean < 1.0);

    // Identical images: zero error.
    let o = ok(&dvsgi(&["compare", b.to_str().unwrap(), b.to_str().unwrap()]));
    assert!(o.contains("RMSE   0.000000") && o.contains("FLIP   mean 0.0000"), "{o}");

    // Bad input: a size mismatch names both files, a missing file is named, a PNG is not
    // radiance, an unknown tone map is a usage error; no error map is left behind.
    let small = dir.path().join("small.exr");
    write_exr(&small, 1, 1, &[1.0; 3]);
    let d2 = dir.path().join("d2.png");
    let t =
        fails(&dvsgi(&["compare", small.to_str().unwrap(), b.to_str().unwrap(), "--diff", d2.to_str().unwrap()]), 1);
    assert!(t.contains("small.exr") && t.contains("b.exr") && t.contains("1x1") && t.contains("2x2"), "{t}");
    assert!(!d2.exists());
    let t = fails(&dvsgi(&["compare", dir.path().join("nope.exr").to_str().unwrap(), b.to_str().unwrap()]), 1);
    assert!(t.contains("nope.exr"), "{t}");
    let t = fails(&dvsgi(&["compare", diff.to_str().unwrap(), b.to_str().unwrap()]), 1);
    assert!(t.contains("diff.png"), "{t}");
    let t = fails(&dvsgi(&["compare", a.to_str().unwrap(), b.to_str().unwrap(), "--tonemap", "filmic"]), 1);
    assert!(t.contains("--tonemap"), "{t}");
}

#[test]
fn reference_writes_radiance_variance_and_display_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("ref.exr");
    let png = dir.path().join("ref.png");
    let o = ok(&dvsgi(&[
        "reference",
        "scenes/cornell-box.toml",
        "--spp",
        "4",
        "--width",
        "16",
        "--height",
        "12",
        "--out",
        exr.to_str().unwrap(),
        "--out",
        png.to_str().unwrap(),
    ]));
    assert!(o.contains("30 triangles"), "{o}");
    for p in [&exr, &dir.path().join("ref.var.exr"), &png] {
        let img = image::open(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert_eq!((img.width(), img.height()), (16, 12));
    }
    let bad = dir.path().join("ref.txt");
    let t = fails(&dvsgi(&["reference", "scenes/cornell-box.toml", "--out", bad.to_str().unwrap()]), 1);
    assert!(t.contains("ref.txt"), "{t}");
    let missing = dir.path().join("missing.toml");
    let t = fails(&dvsgi(&["reference", missing.to_str().unwrap(), "--out", exr.to_str().unwrap()]), 1);
    assert!(t.contains("missing.toml"), "{t}");
    fails(&dvsgi(&["reference", "scenes/cornell-box.toml", "--spp", "0", "--out", exr.to_str().unwrap()]), 2);
    assert!(!bad.exists());
}

#[test]
fn presets_render_and_set_can_override_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.png");
    for p in ["low", "medium", "high", "ultra", "max"] {
        ok(&dvsgi(&[
            "--preset",
            p,
            "render",
            "scenes/cornell-box.toml",
            "--width",
            "16",
            "--height",
            "16",
            "--set",
            "gi.voxel_resolution=16",
            "--out",
            out.to_str().unwrap(),
        ]));
    }
    fails(&dvsgi(&["--preset", "extreme", "info"]), 2);
    // A preset is a whole point on the fronts: it sets the footprint too, and --set still wins.
    let info = |args: &[&str]| ok(&dvsgi(&[&["info", "scenes/cornell-box.toml"], args].concat()));
    let has = |text: &str, line: &str| text.lines().any(|l| l.trim() == line);
    let max = info(&["--preset", "max"]);
    // Its quadrants are the pixels' cones' only (ACCURACY.md, "Quadrants where they pay").
    for line in [
        "footprint = \"quadrants\"",
        "bounce_footprint = \"whole\"",
        "attenuation = \"per-side\"",
        "plane_backs = \"lit\"",
        "cone_filter = \"two-tap\"",
    ] {
        assert!(has(&max, line), "max: no `{line}` in {max}");
    }
    // The default leaves out the backs that close a solid; `ultra` is the default.
    for args in [&[][..], &["--preset", "ultra"][..]] {
        let text = info(args);
        assert!(has(&text, "plane_backs = \"closed\""), "{args:?}: {text}");
    }
    let ultra = info(&["--preset", "ultra", "--set", "gi.footprint=\"quadrants\""]);
    assert!(has(&ultra, "footprint = \"quadrants\""), "{ultra}");
    let low = info(&["--set", "gi.bounce_footprint=\"quadrants\"", "--preset", "low"]);
    assert!(has(&low, "bounce_footprint = \"quadrants\""), "--set applies after the preset: {low}");
}

//! The `dvsgi` binary end to end: every bad input gives one clear message naming the file,
//! a non-zero exit, no panic and no output file; `info` reports the queue topology.

mod common;

use common::{dvsgi_with, repo, stderr, stdout};
use std::path::{Path, PathBuf};

/// Runs a render that must fail: returns stderr after checking exit code, no panic, no file.
fn render_fails(scene: &Path, extra: &[&str], env: &[(&str, &str)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    let mut args =
        vec!["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--width", "32", "--height", "32"];
    args.extend_from_slice(extra);
    let o = dvsgi_with(&args, env);
    let err = stderr(&o);
    assert!(!o.status.success(), "expected failure, got success; stderr:\n{err}");
    assert_eq!(o.status.code(), Some(1), "exit code; stderr:\n{err}");
    assert!(!err.contains("panicked"), "panic:\n{err}");
    assert!(err.contains("error: "), "no error line:\n{err}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "files left behind: {left:?}");
    err
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const CAMERA: &str = "[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\n";
const LIGHT: &str = "[[lights]]\ntype = \"point\"\nposition = [0, 2, 2]\nintensity = [5, 5, 5]\n";

fn scene_with_obj(dir: &Path, obj: &str, mtl: Option<&str>) -> PathBuf {
    write(dir, "m.obj", obj);
    if let Some(m) = mtl {
        write(dir, "m.mtl", m);
    }
    write(dir, "s.toml", &format!("{CAMERA}\n[[objects]]\nobj = \"m.obj\"\n\n{LIGHT}"))
}

/// `render.exposure = "auto"` exposes the PNG so that its lit pixels' log-average luminance is
/// middle grey, whatever the light's strength, and leaves the EXR's radiance as it is.
#[test]
fn auto_exposure_exposes_the_png_and_leaves_the_exr_linear() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str, exposure: &str, extra: &[&str]| {
        let (png, exr) = (dir.path().join(format!("{name}.png")), dir.path().join(format!("{name}.exr")));
        let set = format!("render.exposure={exposure}");
        let mut args = vec!["render", "scenes/cornell-box.toml", "--gi", "none", "--width", "32", "--height", "32"];
        args.extend(["--set", &set]);
        args.extend(extra);
        args.extend(["--out", png.to_str().unwrap(), "--out", exr.to_str().unwrap()]);
        let o = dvsgi_with(&args, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        (image::open(&png).unwrap().to_rgb8(), std::fs::read(&exr).unwrap())
    };
    let (fixed, fixed_exr) = out("fixed", "0", &[]);
    let (auto, auto_exr) = out("auto", "\"auto\"", &[]);
    assert_eq!(fixed_exr, auto_exr, "auto exposure must not touch the EXR");
    // The same scene at 1/64 of its light (6 stops less on every light): the same picture.
    let (dim, _) = out("dim", "\"auto\"", &["--set", "lights.0.intensity=[0.01875, 0.01875, 0.01875]"]);
    let median = |img: &image::RgbImage| {
        let mut g: Vec<u8> = img.pixels().filter(|p| p.0 != [0, 0, 0]).map(|p| p.0[1]).collect();
        g.sort();
        g[g.len() / 2]
    };
    println!("median green: fixed {}, auto {}, auto at 1/64 light {}", median(&fixed), median(&auto), median(&dim));
    assert!((60..=200).contains(&median(&auto)), "auto-exposed median {}", median(&auto));
    assert!(median(&auto).abs_diff(median(&dim)) <= 2, "{} against {}", median(&auto), median(&dim));
}

#[test]
fn render_writes_png_and_exr() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("a.png");
    let exr = dir.path().join("a.exr");
    let o = dvsgi_with(
        &[
            "render",
            "scenes/cornell-box.toml",
            "--out",
            png.to_str().unwrap(),
            "--out",
            exr.to_str().unwrap(),
            "--width",
            "40",
            "--height",
            "30",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("validation"), "{}", stderr(&o));
    assert_eq!(image::open(&png).unwrap().to_rgb8().dimensions(), (40, 30));
    assert_eq!(dvsgi::output::read_rgb_f32(&exr).unwrap().width, 40);
}

#[test]
fn info_reports_device_and_queue_topology() {
    let o = dvsgi_with(&["info", "scenes/cornell-box.toml", "--set", "gi.mode=\"none\""], &[]);
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.contains("queue topology:"), "{out}");
    // render.depth_prepass = "auto": a GPU draws the opaque depth first, a CPU device does not.
    let prepass = if out.contains("  type: CPU\n") { "" } else { "depth prepass -> " };
    let passes = format!("frame data upload -> shadow maps -> {prepass}gbuffer -> deferred lighting -> tonemap");
    assert!(out.contains(&format!("passes (first frame): {passes}\n")), "{out}");
    // The plan the passes were made from: what exists and which views need which targets.
    assert!(
        out.contains("frame plan: ")
            && out.contains("; lit image (G-buffer, lighting); shadow maps: 6 views, sampled by the direct light\n"),
        "{out}"
    );
    // The [gi] table (indented under "  [gi]") names voxel settings; nothing else may.
    let rest: String = out.lines().filter(|l| !l.starts_with("    ")).collect::<Vec<_>>().join("\n");
    assert!(!rest.contains("voxel"), "no voxel passes or volumes without GI:\n{out}");
    assert!(out.contains("  [gi] (with gi.mode=\"none\"):") && out.contains("    mode = \"none\""), "{out}");
    for f in ["timelineSemaphore", "synchronization2", "dynamicRendering", "maintenance4"] {
        assert!(out.contains(f), "{f} missing:\n{out}");
    }
    if common::under_split_queues() {
        // tools/with-split-queues.sh: a second, compute-only family backed by the one queue.
        assert!(out.contains("dedicated compute-only family"), "{out}");
        assert!(out.contains("compute queue: family 1 index 0"), "{out}");
    } else if out.contains("llvmpipe") {
        // lavapipe has one queue family with one queue.
        assert!(out.contains("single-queue fallback"), "{out}");
        assert!(out.contains("compute queue: family 0 index 0"), "{out}");
    }
}

/// `info` describes the bricked layout: the passes that make bricks resident, the resident
/// bricks of each pool against its slots and the grid, and the memory against the dense
/// layout's; and says what the default, "auto", chose on this device (dense where it fits
/// half of the heap: the Cornell box at 256^3 on lavapipe).
#[test]
fn info_describes_the_bricked_voxel_layout() {
    let auto = dvsgi_with(&["info", "scenes/cornell-box.toml", "--set", "gi.voxel_resolution=256"], &[]);
    let out = stdout(&auto);
    assert!(auto.status.success(), "{}", stderr(&auto));
    assert!(out.contains("gi.voxel_layout \"auto\" on this device: dense"), "{out}");
    assert!(out.contains("voxel layout: dense, ") && !out.contains("mark bricks"), "{out}");
    let o = dvsgi_with(
        &["info", "scenes/cornell-box.toml", "--set", "gi.voxel_resolution=256", "--set", "gi.voxel_layout=\"bricks\""],
        &[],
    );
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!out.contains("\"auto\" on this device"), "{out}");
    assert!(out.contains("voxel clear -> mark bricks static -> allocate bricks static -> voxelize static"), "{out}");
    let layout = out.lines().find_map(|l| l.strip_prefix("  voxel layout: bricks of 8³, ")).expect(&out);
    // "X MiB of volumes, maps and lists (R of the dense layout's D MiB)"
    let ratio: f64 =
        layout.split(" (").nth(1).and_then(|r| r.split(' ').next()).and_then(|r| r.parse().ok()).expect(layout);
    assert!(ratio > 0.0 && ratio < 0.5, "{layout}");
    // 256^3 pools the full resolution and the directional level 0 (128^3 > 64^3).
    let pools: Vec<&str> = out.lines().filter(|l| l.starts_with("  bricks, ")).collect();
    assert_eq!(pools.len(), 2, "{out}");
    assert!(pools[0].contains("full resolution (256³ texels, 8³ per brick, 9³ with the radiance apron)"), "{out}");
    assert!(pools[1].contains("directional level 0 (128³ texels, 9³ per brick)"), "{out}");
    for p in pools {
        // "N resident of C slots, M bricks in the grid": 0 < N <= C < M.
        let num = |after: &str| -> u64 {
            p.split(after).next().and_then(|s| s.rsplit(' ').next()).and_then(|n| n.parse().ok()).expect(p)
        };
        let (n, c, m) = (num(" resident of"), num(" slots,"), num(" bricks in the grid"));
        assert!(0 < n && n <= c && c < m, "{p}");
    }
}

/// With voxel GI on a static scene: voxel clear + static voxelization, albedo and normal
/// volumes with their memory, and no emission volume, flag volume or dynamic passes.
// Long: one `info` output, checked line by line against the passes and volumes the scene needs.
#[test]
fn info_lists_only_the_voxel_passes_and_volumes_the_scene_needs() {
    let o = dvsgi_with(
        &[
            "info",
            "scenes/cornell-box.toml",
            "--set",
            "gi.mode=\"vct\"",
            "--set",
            "gi.voxel_resolution=32",
            "--set",
            "gi.voxel_layout=\"dense\"",
        ],
        &[],
    );
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    // With the default gi.plane_backs = "closed" the static voxels' closed backs are marked
    // once, after the static voxelization, in a byte volume of their own.
    assert!(
        out.contains(
            "voxel clear -> voxelize static -> voxel resolve static -> voxel list (static) -> voxel closed backs \
             (static) -> shadow maps"
        ),
        "{out}"
    );
    assert!(out.contains("volume voxel closed backs: "), "{out}");
    // The voxelization's sums: a count, albedo and normal (no emission), 0.12 MiB each.
    assert!(out.contains("volume voxel sum normal z: 0.12 MiB") && !out.contains("voxel sum emission"), "{out}");
    assert!(out.contains("volume voxel albedo: 0.12 MiB") && out.contains("volume voxel normal: 0.12 MiB"), "{out}");
    // The work list (bounded by the triangles' boxes, below 32^3 entries = 0.13 MiB) and what
    // the first frame occupied: the box's walls and blocks, all static, a few percent of the grid.
    let list = out.lines().find_map(|l| l.strip_prefix("  buffer voxel work lists: ")).expect(&out);
    let mib: f64 = list.trim_end_matches(" MiB").parse().expect(list);
    assert!(mib > 0.0 && mib < 0.125, "{list}");
    let line = out.lines().find(|l| l.contains("occupied voxels (first frame):")).expect(&out);
    let words: Vec<&str> = line.split_whitespace().collect();
    let occupied: u64 = words[4].parse().expect(line);
    assert!(words[5..7] == ["of", "32³"] && (1000..8000).contains(&occupied), "{line}");
    assert!(line.contains(&format!("{occupied} static")), "{line}");
    assert!(out.contains("voxel layout: dense"), "{out}");
    for absent in
        ["voxel emission", "voxel static flags", "voxel clear dynamic", "voxelize dynamic", "gi specular", "gi shadow"]
    {
        assert!(!out.contains(absent), "{absent} should not exist:\n{out}");
    }
    // Cone tracing: six directional volumes with their mips, the bounced radiance (and the
    // bounce's scratch volume), the diffuse
    // target; no upsample at full resolution.
    for present in ["voxel mips (voxel radiance)", "voxel bounce", "cone trace -> deferred lighting"] {
        assert!(out.contains(present), "{present} missing:\n{out}");
    }
    assert!(out.contains("volume voxel radiance -z") && out.contains("image gi diffuse"), "{out}");
    assert!(!out.contains("gi upsample") && !out.contains("bounce b"), "{out}");
    // Glossy materials add the specular target; reduced resolution adds the upsample.
    let o = dvsgi_with(
        &["info", "scenes/cornell-glossy.toml", "--set", "gi.voxel_resolution=16", "--set", "gi.downsample=2"],
        &[],
    );
    let out = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.contains("image gi specular (1/2)") && out.contains("cone trace -> gi upsample"), "{out}");
    // No cones without GI: the voxel views that show the volumes themselves build no mips.
    let o = dvsgi_with(
        &[
            "info",
            "scenes/cornell-box.toml",
            "--set",
            "gi.voxel_resolution=16",
            "--set",
            "render.view=\"voxel-albedo\"",
        ],
        &[],
    );
    let out = stdout(&o);
    assert!(out.contains("voxelize static") && !out.contains("voxel mips") && !out.contains("cone trace"), "{out}");
    let o = dvsgi_with(&["info", "scenes/dynamic-test.toml", "--gi", "vct"], &[]);
    assert!(!o.status.success(), "info takes --set, not --gi");
    let o = dvsgi_with(
        &[
            "info",
            "scenes/dynamic-test.toml",
            "--set",
            "gi.mode=\"vct\"",
            "--set",
            "gi.voxel_resolution=16",
            "--set",
            "gi.voxel_layout=\"bricks\"",
        ],
        &[],
    );
    let out = stdout(&o);
    assert!(
        out.contains(
            "voxel clear dynamic -> release bricks dynamic -> mark bricks dynamic -> allocate bricks dynamic -> clear bricks dynamic -> voxelize dynamic -> voxel list (dynamic)"
        ),
        "{out}"
    );
    assert!(out.contains("volume voxel static flags"), "{out}");
}

#[test]
fn voxel_view_renders() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("v.png");
    let o = dvsgi_with(
        &[
            "render",
            "scenes/cornell-box.toml",
            "--view",
            "voxel-normal",
            "--set",
            "gi.voxel_resolution=16",
            "--out",
            png.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "32",
            "-v",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains(
            "passes: frame data upload -> voxel clear -> voxelize static -> voxel resolve static -> voxel list (static) \
             -> voxel view -> tonemap"
        ),
        "{out}"
    );
    let img = image::open(&png).unwrap().to_rgb8();
    // The floor's normal (0, 1, 0) shows as (0.5, 1, 0.5): green-dominant pixels along the
    // bottom rows; the ceiling's (0, -1, 0) as (0.5, 0, 0.5) along the top.
    let count = |rows: std::ops::Range<u32>, f: &dyn Fn(&image::Rgb<u8>) -> bool| {
        rows.flat_map(|y| (0..32).map(move |x| (x, y))).filter(|&(x, y)| f(img.get_pixel(x, y))).count()
    };
    assert!(count(28..32, &|p| p[1] > p[0] + 20 && p[1] > p[2] + 20) >= 8, "floor");
    assert!(count(0..3, &|p| p[0] > p[1] + 20 && p[2] > p[1] + 20) >= 8, "ceiling");
}

#[test]
fn no_vulkan_device_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let none = dir.path().join("none.json");
    let env = [("VK_DRIVER_FILES", none.to_str().unwrap()), ("VK_ICD_FILENAMES", none.to_str().unwrap())];
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &[], &env);
    assert!(err.contains("mesa-vulkan-drivers"), "{err}");
}

#[test]
fn unknown_device_lists_the_available_ones() {
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &["--device", "no-such-gpu"], &[]);
    assert!(err.contains("no-such-gpu") && err.contains("[0]"), "{err}");
}

#[test]
fn missing_scene_file() {
    let err = render_fails(Path::new("scenes/does-not-exist.toml"), &[], &[]);
    assert!(err.contains("does-not-exist.toml"), "{err}");
}

#[test]
fn malformed_toml_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.toml", "[camera]\nposition = [0, 0, 3]\ntarget = [0, 0\n");
    let err = render_fails(&p, &[], &[]);
    assert!(err.contains("bad.toml") && err.contains("line 3"), "{err}");
}

#[test]
fn unknown_key_in_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "k.toml", &format!("{CAMERA}fov = 3\n"));
    let err = render_fails(&p, &[], &[]);
    assert!(err.contains("k.toml") && err.contains("fov"), "{err}");
}

#[test]
fn unknown_set_key_is_named() {
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &["--set", "camera.fovy=45"], &[]);
    assert!(err.contains("camera.fovy"), "{err}");
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &["--set", "camera.fov_y"], &[]);
    assert!(err.contains("KEY=VALUE"), "{err}");
}

#[test]
fn impossible_settings_are_refused() {
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &["--set", "camera.fov_y=-5"], &[]);
    assert!(err.contains("fov_y"), "{err}");
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &["--set", "render.shadow_map_size=0"], &[]);
    assert!(err.contains("shadow_map_size"), "{err}");
}

#[test]
fn missing_obj_lists_where_it_looked() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"nowhere.obj\"\n"));
    let err = render_fails(&p, &[], &[]);
    assert!(err.contains("nowhere.obj") && err.contains("s.toml"), "{err}");
}

#[test]
fn malformed_obj_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with_obj(dir.path(), "v 0 0 0\nv 1 0 0\nv 0 1 abc\nf 1 2 3\n", None);
    let err = render_fails(&p, &[], &[]);
    assert!(err.contains("m.obj") && err.contains("line 3"), "{err}");
}

#[test]
fn obj_index_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with_obj(dir.path(), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", None);
    let err = render_fails(&p, &[], &[]);
    assert!(err.contains("m.obj") && err.contains("line 4"), "{err}");
}

#[test]
fn missing_mtl_is_a_warning_naming_both_files() {
    // As other loaders do: a warning, and the default material.
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with_obj(dir.path(), "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n", None);
    let out = dir.path().join("x.png");
    let o = dvsgi_with(
        &["render", p.to_str().unwrap(), "--out", out.to_str().unwrap(), "--width", "16", "--height", "16"],
        &[],
    );
    let err = stderr(&o);
    assert!(o.status.success() && out.exists(), "{err}");
    assert!(err.contains("warning") && err.contains("gone.mtl") && err.contains("m.obj"), "{err}");
}

#[test]
fn malformed_mtl_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with_obj(
        dir.path(),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
        Some("newmtl a\nKd 0.5 0.5\n"),
    );
    let err = render_fails(&p, &[], &[]);
    assert!(err.contains("m.mtl") && err.contains("line 2"), "{err}");
}

#[test]
fn missing_and_corrupt_textures() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n";
    let p = scene_with_obj(dir.path(), obj, Some("newmtl a\nKd 1 1 1\nmap_Kd missing.png\n"));
    // A missing texture is a warning (the material keeps its Kd colour) ...
    let png = dir.path().join("out.png");
    let o = dvsgi_with(
        &["render", p.to_str().unwrap(), "--out", png.to_str().unwrap(), "--width", "32", "--height", "32"],
        &[],
    );
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("warning: ") && err.contains("m.mtl: line 3") && err.contains("`missing.png`"), "{err}");
    assert!(png.is_file());
    std::fs::remove_file(&png).unwrap();
    // ... a texture that exists but cannot be decoded is an error.
    write(dir.path(), "bad.png", "this is not a png");
    write(dir.path(), "m.mtl", "newmtl a\nKd 1 1 1\nmap_Kd bad.png\n");
    let err = render_fails(&p, &[], &[]);
    assert!(err.contains("bad.png"), "{err}");
}

#[test]
fn textured_material_renders() {
    let dir = tempfile::tempdir().unwrap();
    let tex = image::RgbaImage::from_fn(4, 4, |x, _| {
        if x < 2 {
            image::Rgba([255, 0, 0, 255])
        } else {
            image::Rgba([0, 0, 255, 255])
        }
    });
    tex.save(dir.path().join("t.png")).unwrap();
    let obj = "mtllib m.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl a\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";
    let p = scene_with_obj(dir.path(), obj, Some("newmtl a\nKd 1 1 1\nmap_Kd t.png\n"));
    let exr = dir.path().join("o.exr");
    let o = dvsgi_with(
        &["render", p.to_str().unwrap(), "--out", exr.to_str().unwrap(), "--width", "32", "--height", "32"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let img = dvsgi::output::read_rgb_f32(&exr).unwrap();
    let at = |x: u32, y: u32| {
        let i = ((y * img.width + x) * 3) as usize;
        [img.data[i], img.data[i + 1], img.data[i + 2]]
    };
    // Left half red, right half blue (the quad fills the middle of the view).
    let (l, r) = (at(12, 16), at(20, 16));
    assert!(l[0] > 0.0 && l[1] == 0.0 && l[2] == 0.0, "left {l:?}");
    assert!(r[2] > 0.0 && r[0] == 0.0 && r[1] == 0.0, "right {r:?}");
}

#[test]
fn bad_output_targets() {
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &["--out", "/tmp/x.bmp"], &[]);
    assert!(err.contains("x.bmp") && err.contains(".png"), "{err}");
    let err = render_fails(&repo().join("scenes/cornell-box.toml"), &["--out", "/nonexistent-dir/x.png"], &[]);
    assert!(err.contains("/nonexistent-dir"), "{err}");
}

#[test]
fn every_schedule_is_clean_under_queue_submit_synchronization_validation() {
    // Queue-submit-level sync validation follows hazards across submits and semaphores. It
    // reports false positives with reused timeline semaphores after the first frame (layer
    // 1.3.239), so it checks one frame per mode.
    let env = [(
        "VK_LAYER_ENABLES",
        "VALIDATION_CHECK_ENABLE_SYNCHRONIZATION_VALIDATION,VALIDATION_CHECK_ENABLE_SYNCHRONIZATION_VALIDATION_QUEUE_SUBMIT",
    )];
    let dir = tempfile::tempdir().unwrap();
    for mode in ["sync", "async", "async-lagged", "async-pipelined"] {
        let png = dir.path().join(format!("{mode}.png"));
        let o = dvsgi_with(
            &[
                "render",
                "scenes/cornell-glossy.toml",
                "--set",
                "gi.voxel_resolution=16",
                "--set",
                "gi.downsample=2",
                "--set",
                "gi.shadows=\"cone\"",
                "--width",
                "32",
                "--height",
                "32",
                "--schedule",
                mode,
                "--out",
                png.to_str().unwrap(),
            ],
            &env,
        );
        let err = stderr(&o);
        assert!(o.status.success(), "{mode}: {err}");
        assert!(!err.contains("validation"), "{mode}: {err}");
        let out = stdout(&o);
        assert!(out.contains(&format!("schedule: {mode}")), "{out}");
        if mode != "sync" && common::under_split_queues() {
            assert!(out.contains("dedicated compute-only family"), "{out}");
        }
        if mode != "sync" && out.contains("single-queue") {
            // lavapipe: the output says the compute work shares the one queue.
            assert!(out.contains("compute work goes to the graphics queue"), "{out}");
        }
    }
}

#[test]
fn unknown_schedule_mode_is_a_usage_error() {
    let o = dvsgi_with(&["render", "scenes/cornell-box.toml", "--out", "x.png", "--schedule", "fast"], &[]);
    assert_eq!(o.status.code(), Some(2), "clap usage error");
    assert!(stderr(&o).contains("unknown schedule mode 'fast'"), "{}", stderr(&o));
}

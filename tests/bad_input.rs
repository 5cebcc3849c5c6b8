//! Bad input end to end through the `dvsgi` binary, one test per family: malformed,
//! truncated, empty, binary and wrongly encoded OBJ/MTL/TOML files, non-finite numbers,
//! out-of-range indices, unknown keys and absurd settings. Each failure gives one clear
//! message naming the file (and the line where the loader knows it), exit code 1, no panic
//! and no output file. A missing MTL texture is a warning. The last test replays the inputs
//! the fuzzers found (tests/data/fuzz/) through the fuzz targets' own code.

mod common;

use common::{dvsgi, repo, stderr};
use std::path::{Path, PathBuf};

// The fuzz targets' fixture and per-target functions (tools/fuzz/src/lib.rs).
#[allow(dead_code)]
#[path = "../tools/fuzz/src/lib.rs"]
mod fuzz;

/// Runs `dvsgi render SCENE --out DIR/out.png EXTRA`; checks the
/// failure (exit code 1, an `error: ` line, no panic, nothing written) and that the message
/// contains every one of `parts`. Returns stderr.
fn render_fails(scene: &Path, extra: &[&str], parts: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    // No --width/--height: they would override a --set render.width under test.
    let mut args = vec!["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    let o = dvsgi(&args);
    let err = stderr(&o);
    let what = format!("{} {}", scene.display(), extra.join(" "));
    assert_eq!(o.status.code(), Some(1), "{what}: exit code; stderr:\n{err}");
    assert!(!err.contains("panicked"), "{what}: panic:\n{err}");
    assert!(err.contains("error: "), "{what}: no error line:\n{err}");
    for p in parts {
        assert!(err.contains(p), "{what}: message does not contain {p:?}:\n{err}");
    }
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(left.is_empty(), "{what}: files left behind: {left:?}");
    err
}

/// Renders successfully to DIR/out.exr; returns (stderr, the image's pixels).
fn render_ok(scene: &Path) -> (String, Vec<f32>) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.exr");
    let o =
        dvsgi(&["render", scene.to_str().unwrap(), "--out", out.to_str().unwrap(), "--width", "32", "--height", "32"]);
    let err = stderr(&o);
    assert!(o.status.success(), "{}: {err}", scene.display());
    assert!(!err.contains("panicked") && !err.contains("error"), "{err}");
    (err, dvsgi::output::read_rgb_f32(&out).unwrap().data)
}

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

const CAMERA: &str = "[camera]\nposition = [0, 0, 3]\ntarget = [0, 0, 0]\n";
const LIGHT: &str = "[[lights]]\ntype = \"point\"\nposition = [0, 2, 2]\nintensity = [5, 5, 5]\n";
const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const TRI_MTL: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl a\nf 1/1 2/1 3/1\n";

/// A scene `s.toml` in `dir` with one object `m.obj` and a point light.
fn scene(dir: &Path) -> PathBuf {
    write(dir, "s.toml", format!("{CAMERA}\n[[objects]]\nobj = \"m.obj\"\n\n{LIGHT}"))
}

/// Deterministic "random" bytes (xorshift).
fn noise(n: usize, mut seed: u64) -> Vec<u8> {
    (0..n)
        .map(|_| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 24) as u8
        })
        .collect()
}

fn utf16(s: &str) -> Vec<u8> {
    let mut v = vec![0xff, 0xfe];
    v.extend(s.encode_utf16().flat_map(|u| u.to_le_bytes()));
    v
}

/// The same bad bytes as an OBJ, an MTL and a scene file: each names its file (and line).
#[test]
fn binary_and_wrongly_encoded_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let png = std::fs::read(
        repo()
            .join("docs/images")
            .read_dir()
            .unwrap()
            .flatten()
            .find_map(|e| {
                let p = e.path();
                (p.extension()? == "png").then_some(p)
            })
            .expect("a PNG under docs/images"),
    )
    .unwrap();
    let mut random = noise(4000, 0x9e3779b97f4a7c15);
    random[100] = 0; // random bytes contain a NUL sooner or later; make it sure
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        ("random bytes", random, vec!["NUL byte", "binary"]),
        ("a PNG renamed", png, vec!["this is a PNG image"]),
        ("NUL bytes", b"v 0 0 0\n# x\nv 1\x000 0\n".to_vec(), vec!["line 3: column 4: NUL byte"]),
    ];
    for (what, bytes, parts) in &cases {
        // As the OBJ.
        write(d, "m.obj", bytes);
        let s = scene(d);
        let err = render_fails(&s, &[], &[&["m.obj"], parts.as_slice()].concat());
        assert!(!err.contains("s.toml"), "{what}: the OBJ is to blame:\n{err}");
        // As the MTL of a good OBJ.
        write(d, "m.obj", TRI_MTL);
        write(d, "m.mtl", bytes);
        render_fails(&s, &[], &[&["m.mtl"], parts.as_slice()].concat());
        // As the scene file.
        let t = write(d, "bad.toml", bytes);
        render_fails(&t, &[], &[&["bad.toml"], parts.as_slice()].concat());
    }
}

/// OBJ and MTL files from real exporters come in UTF-16 (with a byte-order mark) and 8-bit
/// encodings: they load (names keep their characters). A scene file must be UTF-8 (TOML).
#[test]
fn utf16_and_latin1_obj_and_mtl_files_load() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene(d);
    let latin1 = |t: &str| t.chars().map(|c| c as u32 as u8).collect::<Vec<u8>>();
    let obj = "mtllib m.mtl\no café\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl rouge é\nf 1 2 3\n";
    let mtl = "newmtl rouge é\nKd 1 0 0\n";
    for (what, o, m) in [("UTF-16", utf16(obj), utf16(mtl)), ("Latin-1", latin1(obj), latin1(mtl))] {
        write(d, "m.obj", &o);
        write(d, "m.mtl", &m);
        let (err, px) = render_ok(&s);
        assert!(!err.contains("not defined"), "{what}: the material name matches across files: {err}");
        assert!(px.chunks(3).any(|p| p[0] > 0.0 && p[1] == 0.0), "{what}: the red material is used");
    }
    for (what, bytes, parts) in [
        ("UTF-16 with BOM", utf16(CAMERA), vec!["bad.toml", "UTF-16", "save it as UTF-8"]),
        ("Latin-1", b"# ok\n# caf\xe9\n".to_vec(), vec!["bad.toml", "line 2: column 6: byte 0xE9 is not valid UTF-8"]),
    ] {
        let t = write(d, "bad.toml", bytes);
        let err = render_fails(&t, &[], &parts);
        assert!(!err.is_empty(), "{what}");
    }
}

#[test]
fn empty_and_truncated_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene(d);
    // OBJ
    for (obj, parts) in [
        ("", vec!["m.obj", "empty (0 bytes)"]),
        ("\n  \n", vec!["m.obj", "empty (only white space)"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1", vec!["m.obj", "line 3", "3 coordinates"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2", vec!["m.obj", "line 4", "at least 3 vertices"]),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1", vec!["m.obj", "line 4", "texture coordinate 1"]),
    ] {
        write(d, "m.obj", obj);
        render_fails(&s, &[], &parts);
    }
    // MTL
    write(d, "m.obj", TRI_MTL);
    for (mtl, parts) in [
        ("", vec!["m.mtl", "empty (0 bytes)"]),
        ("newmtl a\nKd 0.5 0.5", vec!["m.mtl", "line 2", "Kd needs 3 numbers"]),
        ("newmtl a\nNs", vec!["m.mtl", "line 2", "Ns needs a number"]),
        ("newmtl", vec!["m.mtl", "line 1", "newmtl without a material name"]),
    ] {
        write(d, "m.mtl", mtl);
        render_fails(&s, &[], &parts);
    }
    // TOML
    for (toml, parts) in [
        ("", vec!["t.toml", "empty (0 bytes)"]),
        ("[camera]\nposition = [0, 0, 3]\ntarget = [0, 0", vec!["t.toml", "line 3", "invalid array"]),
        ("[camera]\nposition = [0, 0, 3]\n", vec!["t.toml", "missing field `target`"]),
        ("[camera", vec!["t.toml", "line 1"]),
    ] {
        render_fails(&write(d, "t.toml", toml), &[], &parts);
    }
}

#[test]
fn non_finite_numbers_in_obj() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene(d);
    for (obj, line) in [
        ("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", "line 2"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n", "line 3"),
        ("v 1e39 0 0\n", "line 1"),
        ("v 0 0 0\nv 0 0 0 NaN 1 1\n", "line 2"),
        ("v 1 0 0 1e-45\n", "line 1"),
        ("v 0 0 0\nvn 0 0 inf\n", "line 2"),
        ("v 0 0 0\nvt 0.5 NaN\n", "line 2"),
        ("v 0 0 0\nvt 0.5 0.5 inf\n", "line 2"),
    ] {
        write(d, "m.obj", obj);
        render_fails(&s, &[], &["m.obj", line]);
    }
    write(d, "m.obj", TRI_MTL);
    write(d, "m.mtl", "newmtl a\nKd 1 nan 1\n");
    render_fails(&s, &[], &["m.mtl", "line 2", "not a finite number"]);
}

#[test]
fn non_finite_numbers_in_toml() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "m.obj", TRI);
    let obj = "[[objects]]\nobj = \"m.obj\"\n";
    for (toml, key) in [
        ("[camera]\nposition = [0, nan, 3]\ntarget = [0, 0, 0]\n".to_owned(), "camera.position"),
        ("[camera]\nposition = [0, 0, 3]\ntarget = [inf, 0, 0]\n".to_owned(), "camera.target"),
        (format!("{CAMERA}far = inf\n"), "camera.far"),
        (format!("{CAMERA}[render]\nexposure = nan\n"), "render.exposure"),
        (format!("{CAMERA}{obj}translate = [0, -nan, 0]\n"), "objects.0.translate"),
        (format!("{CAMERA}{obj}scale = inf\n"), "objects.0.scale"),
        (format!("{CAMERA}{obj}rotate = [0, 0, nan]\n"), "objects.0.rotate"),
        (
            format!("[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [inf, 1, 1]\n{CAMERA}"),
            "lights.0.intensity",
        ),
        // Finite, but overflowing once combined.
        ("[camera]\nposition = [3e38, 0, 0]\ntarget = [-3e38, 0, 0]\n".to_owned(), "camera.target"),
        (format!("{CAMERA}{obj}scale = 3e38\ntranslate = [3e38, 0, 0]\n"), "objects.0"),
    ] {
        render_fails(&write(d, "t.toml", toml), &[], &["t.toml", key]);
    }
    // The same through --set and --time.
    let s = write(d, "s.toml", format!("{CAMERA}{obj}{LIGHT}"));
    for (set, key) in [
        ("camera.position=[nan, 0, 0]", "camera.position"),
        ("lights.0.intensity=[1, inf, 1]", "lights.0.intensity"),
        ("objects.0.translate=[0, 0, -inf]", "objects.0.translate"),
    ] {
        render_fails(&s, &["--set", set], &["s.toml", key, "not finite"]);
    }
    render_fails(&s, &["--time", "nan"], &["s.toml", "render.time: NaN is not finite"]);
    render_fails(&s, &["--time", "inf"], &["s.toml", "render.time: inf is not finite"]);
}

#[test]
fn face_indices_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene(d);
    for (face, parts) in [
        ("f 1 2 4", vec!["vertex 4 but only 3 vertices"]),
        ("f -1 -2 -4", vec!["vertex -4 but only 3"]),
        ("f 0 1 2", vec!["index 0 is invalid"]),
        ("f 1 2 4294967297", vec!["vertex 4294967297"]),
        ("f 1 2 99999999999999999999", vec!["not an integer"]),
        ("f 1/1 2/1 3/1", vec!["texture coordinate 1 but only 0"]),
        ("f 1//2 2//2 3//2", vec!["normal 2 but only 0"]),
        ("f 1/x 2 3", vec!["not an integer"]),
        ("f 1/1/1/1 2 3", vec!["more than 3"]),
        ("f /1 2 3", vec!["no position index"]),
    ] {
        write(d, "m.obj", format!("v 0 0 0\nv 1 0 0\nv 0 1 0\n{face}\n"));
        render_fails(&s, &[], &[&["m.obj", "line 4"], parts.as_slice()].concat());
    }
}

/// A missing `map_Kd` texture is a warning naming the MTL file, its line, the texture and
/// where it looked; the object renders in its Kd colour. A texture that exists but cannot be
/// decoded stays an error.
#[test]
fn missing_texture_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let obj =
        "mtllib m.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvn 0 0 1\nusemtl a\nf 1/1/1 2/1/1 3/1/1 4/1/1\n";
    write(d, "m.obj", obj);
    write(d, "m.mtl", "newmtl a\nKd 1 0 0\nmap_Kd textures/missing.png\n");
    let (err, px) = render_ok(&scene(d));
    for p in ["warning: ", "m.mtl: line 3", "`textures/missing.png`", "not found", "looked at", "Kd colour"] {
        assert!(err.contains(p), "{p:?} missing:\n{err}");
    }
    assert!(err.contains(&d.join("textures/missing.png").display().to_string()), "{err}");
    // The quad fills the middle of the view: red (Kd), not black or white.
    let i = (16 * 32 + 16) * 3;
    let c = &px[i..i + 3];
    assert!(c[0] > 0.0 && c[1] == 0.0 && c[2] == 0.0, "centre pixel {c:?}");

    write(d, "missing.png", "");
    write(d, "m.mtl", "newmtl a\nKd 1 0 0\nmap_Kd missing.png\n");
    render_fails(&scene(d), &[], &["missing.png", "cannot decode texture", "m.mtl line 3"]);
    std::fs::remove_file(d.join("missing.png")).unwrap();
    std::fs::create_dir(d.join("missing.png")).unwrap();
    render_fails(&scene(d), &[], &["m.mtl", "line 3", "missing.png", "is not a file"]);
}

#[test]
fn unknown_keys() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "m.obj", TRI);
    for (toml, parts) in [
        (format!("{CAMERA}fov = 3\n"), vec!["line 4", "unknown field `fov`", "fov_y"]),
        (format!("{CAMERA}[bogus]\nx = 1\n"), vec!["line 4", "unknown field `bogus`"]),
        (format!("{CAMERA}[render]\nwidht = 3\n"), vec!["line 5", "unknown field `widht`", "width"]),
        (format!("{CAMERA}[gi]\nvoxels = 64\n"), vec!["line 5", "unknown field `voxels`"]),
        (format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\nmove = 1\n"), vec!["line 6", "unknown field `move`"]),
        (format!("{CAMERA}{LIGHT}colour = [1, 1, 1]\n"), vec!["unknown field `colour`"]),
        (format!("{CAMERA}{LIGHT}irradiance = [1, 1, 1]\n"), vec!["lights.0.irradiance", "does not apply"]),
        (format!("{CAMERA}[[lights]]\ntype = \"area\"\n"), vec!["lights.0.type", "unknown light type"]),
    ] {
        render_fails(&write(d, "k.toml", toml), &[], &[&["k.toml"], parts.as_slice()].concat());
    }
    let s = write(d, "s.toml", format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n{LIGHT}"));
    for (set, parts) in [
        ("camera.fovy=45", vec!["s.toml", "camera.fovy", "no key `fovy`", "fov_y"]),
        ("lights.3.intensity=[1,1,1]", vec!["s.toml", "index 3 is out of range"]),
        ("render.width.x=1", vec!["s.toml", "is a value, not a table"]),
        ("camera..fov_y=1", vec!["empty component"]),
        ("=1", vec!["empty key"]),
        ("camera.fov_y", vec!["KEY=VALUE"]),
    ] {
        render_fails(&s, &["--set", set], &parts);
    }
}

#[test]
fn absurd_settings() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "m.obj", TRI);
    let s = write(d, "s.toml", format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n{LIGHT}"));
    for (set, parts) in [
        ("render.width=0", vec!["render.width: 0 is not in 1..=16384"]),
        ("render.width=1000000000", vec!["render.width: 1000000000 is not in 1..=16384"]),
        ("render.height=0", vec!["render.height"]),
        ("render.width=-1", vec!["expected u32"]),
        ("render.width=1e9", vec!["expected u32"]),
        ("camera.fov_y=0", vec!["camera.fov_y: 0 is not in (0, 180)"]),
        ("camera.fov_y=-5", vec!["camera.fov_y: -5"]),
        ("camera.fov_y=180", vec!["camera.fov_y: 180"]),
        ("camera.fov_y=1000", vec!["camera.fov_y: 1000"]),
        ("camera.near=0", vec!["camera.near: 0 must be > 0"]),
        ("camera.near=-1", vec!["camera.near: -1 must be > 0"]),
        ("camera.near=2000", vec!["camera.far: 1000 must be greater than near (2000)"]),
        ("camera.far=0.01", vec!["camera.far"]),
        ("render.shadow_map_size=0", vec!["render.shadow_map_size: 0 is not in 16..=8192"]),
        ("render.shadow_map_size=4000000000", vec!["render.shadow_map_size: 4000000000"]),
        ("render.exposure=1e30", vec!["render.exposure", "-64..=64"]),
        ("gi.voxel_resolution=100000", vec!["gi.voxel_resolution"]),
        ("gi.diffuse_cones=0", vec!["gi.diffuse_cones"]),
        ("camera.target=[0, 0, 3]", vec!["camera.target", "same point"]),
        ("camera.up=[0, 0, 0]", vec!["camera.up"]),
    ] {
        // The values given on the command line are checked against the scene file.
        render_fails(&s, &["--set", set], &[&["s.toml"], parts.as_slice()].concat());
    }
    // And in the file itself (the CLI's --width/--height would override these, so none).
    for (toml, part) in [
        (format!("{CAMERA}[render]\nwidth = 0\n"), "render.width"),
        (format!("{CAMERA}near = 5\nfar = 5\n"), "camera.far"),
    ] {
        let p = write(d, "a.toml", toml);
        let out = d.join("o/out.png");
        std::fs::create_dir_all(d.join("o")).unwrap();
        let o = dvsgi(&["render", p.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains("a.toml") && stderr(&o).contains(part), "{}", stderr(&o));
        assert!(!out.exists());
    }
}

/// Command-line arguments out of range are usage errors (exit code 2, from the argument
/// parser) that name the limit; nothing is rendered.
#[test]
fn absurd_command_line_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let out = out.to_str().unwrap();
    for (args, part) in [
        (vec!["--frames", "1000000000"], "1000000000 is not in 1..=1000"),
        (vec!["--frames", "0"], "0 is not in 1..=1000"),
        (vec!["--frames", "99999999999999999999"], "--frames"),
        (vec!["--width", "-1"], "unexpected argument '-1'"),
        (vec!["--width", "1e9"], "invalid value '1e9' for '--width"),
        (vec!["--width", "4294967296"], "invalid value '4294967296'"),
    ] {
        let mut a = vec!["render", "scenes/cornell-box.toml", "--out", out];
        a.extend_from_slice(&args);
        let o = dvsgi(&a);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(part) && !err.contains("panicked"), "{args:?}: {err}");
        assert!(!Path::new(out).exists());
    }
    // Values the parser accepts but the scene refuses are errors naming the key (exit 1).
    render_fails(&repo().join("scenes/cornell-box.toml"), &["--width", "0"], &["render.width: 0"]);
    render_fails(&repo().join("scenes/cornell-box.toml"), &["--width", "1000000000"], &["render.width: 1000000000"]);
    let o = dvsgi(&["sweep", "scenes/cornell-box.toml", "--out", out, "--warmup", "4000000000"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("0..=10000"), "{}", stderr(&o));
}

/// Zero-length normals and zero-area triangles are kept; the renderer copes: no NaN pixels.
#[test]
fn degenerate_geometry_renders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv 2 2 0\nvn 0 0 0\n\
               f 1//1 2//1 3//1 4//1\nf 1//1 2//1 2//1\nf 5 5 5\nf 1 3 5\n";
    write(d, "m.obj", obj);
    let (_, px) = render_ok(&scene(d));
    assert!(px.iter().all(|v| v.is_finite()), "non-finite pixels");
    assert!(px.iter().any(|&v| v > 0.0), "the lit quad is visible");
}

/// Every input the fuzzers found (tests/data/fuzz/<target>/) through the fuzz target's own
/// code: no panic, and a loaded scene satisfies `Scene::check_invariants`, an error names its
/// file.
#[test]
fn fuzz_regressions() {
    let fixture = tempfile::tempdir().unwrap();
    fuzz::fixture_in(fixture.path());
    for (target, run) in [
        ("scene_toml", fuzz::scene_toml as fn(&Path, &[u8]) -> bool),
        ("obj_mtl", fuzz::obj_mtl),
        ("set_override", fuzz::set_override),
    ] {
        let mut n = 0;
        for dir in [repo().join("tests/data/fuzz").join(target), repo().join("tools/fuzz/seeds").join(target)] {
            // Both are part of the repository: a missing one is a failure, never a silent skip.
            let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
            for e in entries.flatten() {
                let data = std::fs::read(e.path()).unwrap();
                let r = std::panic::catch_unwind(|| run(fixture.path(), &data));
                let loaded = r.unwrap_or_else(|_| panic!("{target}: {} failed", e.path().display()));
                // The hand-written seeds are valid, except those named bad*.
                if dir.ends_with(Path::new("seeds").join(target)) {
                    let bad = e.file_name().to_string_lossy().starts_with("bad");
                    assert_eq!(loaded, !bad, "{target}: seed {}", e.path().display());
                }
                n += 1;
            }
        }
        assert!(n > 10, "{target}: only {n} stored inputs");
    }
}

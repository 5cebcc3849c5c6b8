//! The fuzz targets' code: the fixture files the fuzzed inputs refer to, one function per
//! target that runs an input through `dvsgi::scene::load`, and the checks every result must
//! pass. tests/bad_input.rs includes this file (`#[path]`) to replay the stored findings
//! through exactly the same code.

use dvsgi::scene::{LoadOptions, Scene, SceneError};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Separates the OBJ part from the MTL part of an `obj_mtl` input.
pub const SEPARATOR: &[u8] = b"\n%%MTL%%\n";

/// The repository's `scenes/` directory (this file is built from tools/fuzz and, for the
/// tests, from the repository root).
fn scenes() -> PathBuf {
    let m = Path::new(env!("CARGO_MANIFEST_DIR"));
    if m.join("scenes").is_dir() {
        m.join("scenes")
    } else {
        m.join("../../scenes")
    }
}

/// A small valid textured OBJ (two groups, normals, uvs, a negative index).
pub const OBJ: &str = "mtllib ok.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
vn 0 0 1\ng front\nusemtl tex\nf 1/1/1 2/2/1 3/3/1\ng back\nusemtl red\nf -4/-4/-1 -2/-2/-1 -1/-1/-1\n";
pub const MTL: &str =
    "newmtl tex\nKd 1 1 1\nmap_Kd t.png\nnewmtl red\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 50\nKe 0 0 0\n";
/// The fixed scene of the `obj_mtl` and `set_override` targets (its object is `m.obj`).
pub const SCENE: &str = r#"[scene]
name = "fuzz"
[camera]
position = [0, 0, 4]
target = [0, 0, 0]
fov_y = 50
[render]
width = 64
height = 48
[gi]
mode = "vct"
voxel_resolution = 32
[[materials]]
name = "white"
albedo = [0.8, 0.8, 0.8]
[[materials]]
name = "tex"
albedo_texture = "t.png"
[[objects]]
obj = "m.obj"
[[objects]]
obj = "ok.obj"
material = "white"
translate = [0, 1, 0]
scale = [1, 2, 1]
dynamic = true
[objects.motion]
degrees_per_second = 10
velocity = [0.1, 0, 0]
[[objects]]
obj = "ok.obj"
materials = { front = "tex" }
dynamic = true
keyframes = [{ time = 0, translate = [0, 0, 0] }, { time = 1, rotate = [0, 90, 0], scale = 2 }]
[[lights]]
type = "point"
position = [0, 2, 2]
intensity = [5, 5, 5]
[[lights]]
type = "directional"
direction = [0, -1, 0]
irradiance = [1, 1, 1]
[[lights]]
type = "spot"
position = [0, 3, 0]
direction = [0, -1, 0]
intensity = [10, 10, 10]
inner_angle = 10
outer_angle = 20
[lights.motion]
velocity = [0, 0, 1]
"#;

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        if e.path().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// Fills `d` with the fixture: `ok.obj`/`ok.mtl`, an `m.obj` (the same), a texture `t.png`,
/// an undecodable `bad.png`, and copies of the repository's `scenes/cornell-box` and
/// `scenes/cube` (so the shipped scene files, used as seeds, find their geometry).
pub fn fixture_in(d: &Path) {
    std::fs::create_dir_all(d).unwrap();
    std::fs::write(d.join("ok.obj"), OBJ).unwrap();
    std::fs::write(d.join("ok.mtl"), MTL).unwrap();
    std::fs::write(d.join("m.obj"), OBJ).unwrap();
    std::fs::write(d.join("bad.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    // A valid 2x2 RGB PNG.
    let png: [u8; 75] = [
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
        0x00, 0x02, 0x00, 0x00, 0x00, 0x02, 0x08, 0x02, 0x00, 0x00, 0x00, 0xfd, 0xd4, 0x9a, 0x73, 0x00, 0x00, 0x00,
        0x12, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xcf, 0xc0, 0xc0, 0x00, 0xc2, 0x0c, 0xff, 0x81, 0x00,
        0x00, 0x1f, 0xee, 0x05, 0xfb, 0x0b, 0xd9, 0x68, 0x8b, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae,
        0x42, 0x60, 0x82,
    ];
    std::fs::write(d.join("t.png"), png).unwrap();
    for sub in ["cornell-box", "cube"] {
        copy_dir(&scenes().join(sub), &d.join(sub));
    }
    for sub in ["obj_mtl"] {
        std::fs::create_dir_all(d.join(sub)).unwrap();
        for f in ["t.png", "bad.png", "ok.obj", "ok.mtl"] {
            std::fs::copy(d.join(f), d.join(sub).join(f)).unwrap();
        }
        std::fs::write(d.join(sub).join("scene.toml"), SCENE).unwrap();
    }
    std::fs::write(d.join("set.toml"), SCENE).unwrap();
}

/// This process's fixture directory (created once per process, in the temp directory).
pub fn workdir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("dvsgi-fuzz-{}", std::process::id()));
        fixture_in(&d);
        d
    })
}

/// `scene_toml`: `data` is a scene file (any bytes), loaded from the fixture directory `dir`.
pub fn scene_toml(dir: &Path, data: &[u8]) -> bool {
    let path = dir.join("scene.toml");
    std::fs::write(&path, data).unwrap();
    load_and_check(&path, Vec::new())
}

/// `obj_mtl`: `data` is an OBJ and an MTL separated by [`SEPARATOR`], written as `m.obj` and
/// `m.mtl` next to the fixed valid scene [`SCENE`] that loads `m.obj`.
pub fn obj_mtl(dir: &Path, data: &[u8]) -> bool {
    let (obj, mtl) = match data.windows(SEPARATOR.len()).position(|w| w == SEPARATOR) {
        Some(i) => (&data[..i], &data[i + SEPARATOR.len()..]),
        None => (data, &[][..]),
    };
    let dir = dir.join("obj_mtl");
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    std::fs::write(dir.join("m.mtl"), mtl).unwrap();
    load_and_check(&dir.join("scene.toml"), Vec::new())
}

/// `set_override`: `data` is a list of `--set KEY=VALUE` arguments, one per line (non-UTF-8
/// input is skipped: command-line arguments are strings), applied to [`SCENE`].
pub fn set_override(dir: &Path, data: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(data) else { return false };
    let mut overrides = Vec::new();
    for line in text.lines() {
        match dvsgi::scene::parse_override(line) {
            Ok(kv) => overrides.push(kv),
            Err(e) => {
                // A malformed argument names itself.
                let msg = e.to_string();
                assert!(msg.starts_with("--set ") && msg.len() > 6, "{msg}");
                return false;
            }
        }
    }
    load_and_check(&dir.join("set.toml"), overrides)
}

/// Asserts what must hold for any input: on success the scene's invariants
/// ([`Scene::check_invariants`]); on failure a non-empty message that names the file the
/// error is about. Returns whether the scene loaded.
pub fn check(result: Result<Scene, SceneError>) -> bool {
    match result {
        Ok(scene) => {
            if let Err(e) = scene.check_invariants() {
                panic!("loaded scene violates an invariant: {e}");
            }
            true
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(!msg.trim().is_empty(), "empty error message: {e:?}");
            if let Some(p) = e.path() {
                let shown = p.display().to_string();
                assert!(msg.contains(&shown), "message does not name {shown}: {msg}");
            }
            false
        }
    }
}

/// Loads `path` with default options plus `overrides`, and checks the result; whether it
/// loaded.
pub fn load_and_check(path: &Path, overrides: Vec<(String, String)>) -> bool {
    check(dvsgi::scene::load(path, &LoadOptions { overrides, asset_paths: Vec::new() }))
}

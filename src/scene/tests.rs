//! Tests of the scene-loading layer (shipped scenes, overrides, every error path).

use super::*;
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

/// The repository root (works both in the crate and when this module is built elsewhere
/// through `#[path]`).
fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn scenes_dir() -> PathBuf {
    repo_root().join("scenes")
}

/// The shared test data (`../shared/scenes` next to the repository) must be present:
/// these tests fail rather than skip without it.
fn require_shared() {
    let p = scenes_dir().join("../../shared/scenes/cornell-box/CornellBox-Original.obj");
    assert!(p.is_file(), "{} not found: the shared test scenes must sit next to the repository", p.display());
}

fn load_default(p: &Path) -> Result<Scene, SceneError> {
    load(p, &LoadOptions::default())
}

fn with_overrides(p: &Path, o: &[&str]) -> Result<Scene, SceneError> {
    let overrides = o.iter().map(|s| parse_override(s)).collect::<Result<Vec<_>, _>>()?;
    load(p, &LoadOptions { overrides, asset_paths: Vec::new() })
}

fn write(dir: &Path, name: &str, content: &str) -> PathBuf {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, content).unwrap();
    p
}

fn err_of(r: Result<Scene, SceneError>) -> SceneError {
    match r {
        Ok(_) => panic!("expected an error, got a scene"),
        Err(e) => e,
    }
}

/// Asserts the message contains all of `parts`, printing it otherwise.
fn assert_msg(e: &SceneError, parts: &[&str]) {
    let m = e.to_string();
    for p in parts {
        assert!(m.contains(p), "message does not contain {p:?}:\n{m}");
    }
}

const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\n";

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A scene in a temp dir with one object `tri.obj` (a triangle) plus `extra` TOML.
fn tri_scene(dir: &Path, extra: &str) -> PathBuf {
    write(dir, "tri.obj", TRI_OBJ);
    write(dir, "scene.toml", &format!("{CAMERA}\n[[objects]]\nobj = \"tri.obj\"\n{extra}"))
}

fn mesh<'a>(s: &'a Scene, name: &str) -> &'a Mesh {
    s.meshes.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no mesh {name}"))
}

fn approx(a: Vec3, b: Vec3, eps: f32) -> bool {
    (a - b).abs().max_element() <= eps
}

// ---------------------------------------------------------------------------------------------
// Shipped scenes
// ---------------------------------------------------------------------------------------------

#[test]
fn every_shipped_scene_loads() {
    require_shared();
    let mut n = 0;
    for e in std::fs::read_dir(scenes_dir()).unwrap() {
        let p = e.unwrap().path();
        if p.extension().and_then(|x| x.to_str()) != Some("toml") {
            continue;
        }
        let s = load_default(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert!(!s.meshes.is_empty(), "{}", p.display());
        assert!(!s.lights.is_empty(), "{}", p.display());
        for m in &s.meshes {
            assert_eq!(m.positions.len(), m.normals.len());
            assert_eq!(m.positions.len(), m.uvs.len());
            assert_eq!(m.indices.len() % 3, 0);
            assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
            assert!((m.material as usize) < s.materials.len());
            assert!(m.normals.iter().all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-3));
            assert!(m.positions.iter().all(|p| p.is_finite()));
        }
        assert!(!s.world_bounds(s.settings.time).is_empty());
        n += 1;
    }
    assert!(n >= 9, "found only {n} scenes");
}

#[test]
fn authored_cornell_box_matches_published_data() {
    let s = load_default(&scenes_dir().join("cornell-box.toml")).unwrap();
    assert_eq!(s.name, "Cornell box");
    let b = s.world_bounds(0.0);
    assert!(approx(b.min, Vec3::ZERO, 1e-5), "{b:?}");
    assert!(approx(b.max, Vec3::new(0.556, 0.5488, 0.5592), 1e-5), "{b:?}");
    assert_eq!(s.meshes.len(), 7);
    let white = Vec3::new(0.725, 0.71, 0.68);
    let expect = [
        ("floor", white),
        ("ceiling", white),
        ("backWall", white),
        ("leftWall", Vec3::new(0.63, 0.065, 0.05)),
        ("rightWall", Vec3::new(0.14, 0.45, 0.091)),
        ("shortBlock", white),
        ("tallBlock", white),
    ];
    for (name, albedo) in expect {
        let m = mesh(&s, name);
        let mat = &s.materials[m.material as usize];
        assert!(approx(mat.albedo, albedo, 1e-6), "{name}: {mat:?}");
        assert_eq!(mat.specular, Vec3::ZERO);
        assert!(!mat.is_emissive());
    }
    // Red wall at x ~0.55, green at x = 0; short block top at 0.165, tall at 0.33.
    assert!(mesh(&s, "leftWall").bounds.min.x > 0.549);
    assert_eq!(mesh(&s, "rightWall").bounds.max.x, 0.0);
    assert!((mesh(&s, "shortBlock").bounds.max.y - 0.165).abs() < 1e-6);
    assert!((mesh(&s, "tallBlock").bounds.max.y - 0.33).abs() < 1e-6);
    assert_eq!(mesh(&s, "shortBlock").indices.len(), 5 * 6);

    // Floor normal +y; every wall normal points into the room, block normals outward,
    // and the winding agrees with the normals.
    assert!(mesh(&s, "floor").normals.iter().all(|n| approx(*n, Vec3::Y, 1e-6)));
    let room_c = Vec3::new(0.278, 0.2744, 0.2796);
    for m in &s.meshes {
        let centroid = m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32;
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let d = if m.name.ends_with("Block") { *p - centroid } else { room_c - *p };
            assert!(n.dot(d) > 0.0, "{}: normal {n} at {p}", m.name);
        }
        for t in m.indices.chunks(3) {
            let (a, b, c) = (m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]);
            let geo = (b - a).cross(c - a);
            assert!(geo.dot(m.normals[t[0] as usize]) > 0.0, "{} winding", m.name);
        }
    }

    // Camera and light as in the published setup.
    assert_eq!(s.camera.position, Vec3::new(0.278, 0.273, -0.8));
    assert_eq!(s.camera.fov_y_deg, 39.3);
    match &s.lights[0].kind {
        LightKind::Point { position, intensity } => {
            assert_eq!(*position, Vec3::new(0.278, 0.4988, 0.2796));
            assert_eq!(*intensity, Vec3::splat(1.2));
        }
        k => panic!("{k:?}"),
    }
    assert_eq!((s.settings.width, s.settings.height), (512, 512));
    assert!(!s.has_dynamic());
}

#[test]
fn sponza_loads_with_all_triangles() {
    require_shared();
    let s = load_default(&scenes_dir().join("sponza.toml")).unwrap();
    assert_eq!(s.triangle_count(), 66_454);
    assert_eq!(s.meshes.len(), 34);
    let b = s.world_bounds(0.0);
    assert!(approx(b.min, Vec3::new(-17.4, -0.91, -7.8), 0.05), "{b:?}");
    assert!(approx(b.max, Vec3::new(17.42, 15.65, 7.8), 0.05), "{b:?}");
    let mat = |g: &str| s.materials[mesh(&s, g).material as usize].name.clone();
    assert_eq!(mat("floors"), "floor_stone");
    assert_eq!(mat("doors"), "wood");
    assert_eq!(mat("arcs_01"), "sandstone");
    assert!(matches!(s.lights[0].kind, LightKind::Directional { .. }));
    assert!(s.bounds.is_some());
    assert_eq!((s.settings.width, s.settings.height), (640, 360));
}

#[test]
fn mcguire_variants_keep_emissive_light() {
    require_shared();
    for f in [
        "cornell-original.toml",
        "cornell-sphere.toml",
        "cornell-glossy.toml",
        "cornell-mirror.toml",
        "cornell-water.toml",
        "cornell-empty-rg.toml",
    ] {
        let s = load_default(&scenes_dir().join(f)).unwrap();
        let light = mesh(&s, "light");
        assert!(s.materials[light.material as usize].is_emissive(), "{f}: light group not emissive");
        // The point light is inside the box, under the ceiling.
        let b = s.world_bounds(0.0);
        if let LightKind::Point { position, .. } = s.lights[0].kind {
            assert!(position.y < b.max.y && position.y > b.max.y - 0.1, "{f}");
        }
    }
}

#[test]
fn glossy_obj_missing_light_material_falls_back_to_default() {
    require_shared();
    let dir = tempfile::tempdir().unwrap();
    let shared = scenes_dir().join("../../shared/scenes");
    let p = write(
        dir.path(),
        "g.toml",
        &format!(
            "[scene]\nsearch_paths = [{:?}]\n{CAMERA}\n[[objects]]\nobj = \"cornell-box/CornellBox-Glossy.obj\"\n",
            shared.display().to_string()
        ),
    );
    let s = load_default(&p).unwrap();
    let m = &s.materials[mesh(&s, "light").material as usize];
    assert_eq!(m.name, "default");
    assert_eq!(m.albedo, Vec3::splat(0.8));
    let f = &s.materials[mesh(&s, "floor").material as usize];
    assert_eq!(f.name, "floor");
    assert!(!f.is_glossy());
    let sphere = &s.materials[mesh(&s, "sphere").material as usize];
    assert_eq!(sphere.specular, Vec3::splat(0.9));
}

#[test]
fn dynamic_test_scene_moves() {
    let s = load_default(&scenes_dir().join("dynamic-test.toml")).unwrap();
    assert!(s.has_dynamic());
    let spinner = s.objects.iter().find(|o| o.name == "spinner").unwrap();
    assert!(spinner.dynamic);
    let slider = s.objects.iter().find(|o| o.name == "slider").unwrap();
    let p0 = slider.model_matrix(0.0).transform_point3(Vec3::ZERO);
    let p1 = slider.model_matrix(1.0).transform_point3(Vec3::ZERO);
    assert!(approx(p0, Vec3::new(0.10, 0.02, 0.032), 1e-6));
    assert!(approx(p1, Vec3::new(0.275, 0.02, 0.032), 1e-6));
    // Everything stays inside the box.
    let b = s.world_bounds(1.3);
    assert!(b.min.min_element() >= -1e-6 && b.max.y <= 0.5488 + 1e-6);
}

// ---------------------------------------------------------------------------------------------
// Overrides
// ---------------------------------------------------------------------------------------------

#[test]
fn overrides_apply() {
    let p = scenes_dir().join("cornell-box.toml");
    let s = with_overrides(
        &p,
        &[
            "camera.fov_y=45",
            "lights.0.intensity=[1,2,3]",
            "render.width=64",
            "objects.0.dynamic=true",
            "render.tonemap=reinhard",
            "render.time = 2.5",
            "scene.name=renamed",
        ],
    )
    .unwrap();
    assert_eq!(s.camera.fov_y_deg, 45.0);
    assert_eq!(s.settings.width, 64);
    assert_eq!(s.settings.height, 512);
    assert_eq!(s.settings.time, 2.5);
    assert_eq!(s.settings.tonemap, ToneMap::Reinhard);
    assert!(s.objects[0].dynamic);
    assert_eq!(s.name, "renamed");
    match &s.lights[0].kind {
        LightKind::Point { intensity, .. } => assert_eq!(*intensity, Vec3::new(1.0, 2.0, 3.0)),
        k => panic!("{k:?}"),
    }
}

#[test]
fn override_can_add_optional_tables_and_group_materials() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "two.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\ng a\nf 1 2 3\ng b\nf 1 3 2\n");
    let p = write(
        dir.path(),
        "s.toml",
        &format!("{CAMERA}\n[[materials]]\nname = \"red\"\nalbedo = [1, 0, 0]\n[[objects]]\nobj = \"two.obj\"\n"),
    );
    let s = with_overrides(
        &p,
        &[
            "objects.0.materials.b=red",
            "objects.0.dynamic=true",
            "objects.0.motion.degrees_per_second=90",
            "scene.bounds={ min = [-1,-1,-1], max = [1,1,1] }",
        ],
    )
    .unwrap();
    assert_eq!(s.materials[mesh(&s, "b").material as usize].name, "red");
    assert_eq!(s.materials[mesh(&s, "a").material as usize].name, "default");
    assert!(matches!(s.objects[0].motion, Motion::Parametric { .. }));
    assert_eq!(s.bounds.unwrap().max, Vec3::ONE);
}

#[test]
fn unknown_override_key_is_named() {
    let p = scenes_dir().join("cornell-box.toml");
    let e = err_of(with_overrides(&p, &["camera.fovy=45"]));
    assert!(matches!(e, SceneError::UnknownKey { .. }), "{e:?}");
    assert_msg(&e, &["camera.fovy", "fov_y", "cornell-box.toml"]);

    let e = err_of(with_overrides(&p, &["lights.3.intensity=[1,1,1]"]));
    assert!(matches!(e, SceneError::UnknownKey { .. }), "{e:?}");
    assert_msg(&e, &["lights.3.intensity", "out of range", "0"]);

    let e = err_of(with_overrides(&p, &["bogus=1"]));
    assert_msg(&e, &["bogus", "camera", "render", "lights"]);

    let e = err_of(with_overrides(&p, &["camera.fov_y.x=1"]));
    assert_msg(&e, &["camera.fov_y.x", "not a table"]);

    let e = err_of(with_overrides(&p, &["render.width=abc"]));
    assert!(matches!(e, SceneError::Toml { .. }), "{e:?}");
    assert_msg(&e, &["render.width=abc", "cornell-box.toml"]);

    let e = err_of(with_overrides(&p, &["render.width=0"]));
    assert_msg(&e, &["render.width", "1..=16384"]);
}

#[test]
fn parse_override_syntax() {
    assert_eq!(parse_override("a.b.c=value").unwrap(), ("a.b.c".to_owned(), "value".to_owned()));
    assert_eq!(parse_override("x=[1, 2]=3").unwrap(), ("x".to_owned(), "[1, 2]=3".to_owned()));
    let e = parse_override("camera.fov_y").unwrap_err();
    assert!(matches!(e, SceneError::BadOverride { .. }));
    assert_msg(&e, &["camera.fov_y", "KEY=VALUE"]);
    assert!(parse_override("=3").is_err());
    let e = err_of(with_overrides(&scenes_dir().join("cornell-box.toml"), &["camera..fov_y=3"]));
    assert!(matches!(e, SceneError::BadOverride { .. }));
}

#[test]
fn override_key_lists_match_the_schema() {
    use super::file::*;
    fn expected<T: serde::de::DeserializeOwned + std::fmt::Debug>(tbl: &str) -> Vec<String> {
        let e = toml::from_str::<T>(&format!("{tbl}zzz_unknown = 1\n")).unwrap_err();
        let m = e.to_string();
        let tail = m.split("expected").nth(1).unwrap_or_else(|| panic!("{m}"));
        let mut v: Vec<String> = tail.split('`').skip(1).step_by(2).map(str::to_owned).collect();
        v.sort();
        v
    }
    fn sorted(k: &[&str]) -> Vec<String> {
        let mut v: Vec<String> = k.iter().map(|s| s.to_string()).collect();
        v.sort();
        v
    }
    assert_eq!(expected::<SceneFile>(""), sorted(TOP_KEYS));
    assert_eq!(expected::<SceneSection>(""), sorted(SCENE_KEYS));
    assert_eq!(expected::<BoundsDef>(""), sorted(BOUNDS_KEYS));
    assert_eq!(expected::<CameraDef>(""), sorted(CAMERA_KEYS));
    assert_eq!(expected::<RenderDef>(""), sorted(RENDER_KEYS));
    assert_eq!(expected::<GiDef>(""), sorted(GI_KEYS));
    assert_eq!(expected::<MaterialDef>(""), sorted(MATERIAL_KEYS));
    assert_eq!(expected::<ObjectDef>(""), sorted(OBJECT_KEYS));
    assert_eq!(expected::<MotionDef>(""), sorted(MOTION_KEYS));
    assert_eq!(expected::<KeyframeDef>(""), sorted(KEYFRAME_KEYS));
    assert_eq!(expected::<LightDef>(""), sorted(LIGHT_KEYS));
    assert_eq!(expected::<super::sky::SkyDef>("type = \"none\"\n"), sorted(super::sky::SKY_KEYS));
}

// ---------------------------------------------------------------------------------------------
// Scene-file errors
// ---------------------------------------------------------------------------------------------

#[test]
fn missing_scene_file() {
    let e = err_of(load_default(Path::new("/nonexistent/dir/nope.toml")));
    assert!(matches!(e, SceneError::Io { .. }));
    assert_msg(&e, &["nope.toml", "cannot read"]);
}

#[test]
fn malformed_toml_reports_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.toml", "[camera]\nposition = [0, 0, 5\n");
    let e = err_of(load_default(&p));
    assert!(matches!(e, SceneError::Toml { .. }));
    assert_msg(&e, &["bad.toml", "line 2"]);
}

#[test]
fn unknown_key_in_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "k.toml", "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfovy = 30\n");
    let e = err_of(load_default(&p));
    assert_msg(&e, &["k.toml", "line 4", "fovy", "fov_y"]);
}

#[test]
fn wrong_type_in_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "t.toml", "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = \"wide\"\n");
    let e = err_of(load_default(&p));
    assert_msg(&e, &["t.toml", "line 4", "invalid type"]);
    let p = write(dir.path(), "t2.toml", &format!("{CAMERA}[[objects]]\nobj = \"x.obj\"\nscale = \"big\"\n"));
    assert_msg(&err_of(load_default(&p)), &["t2.toml", "line 6", "a number or an array of 3"]);
    let p = write(dir.path(), "t3.toml", "[render]\nwidth = 10\n");
    assert_msg(&err_of(load_default(&p)), &["t3.toml", "camera"]);
}

#[test]
fn missing_obj_lists_tried_paths() {
    let dir = tempfile::tempdir().unwrap();
    let extra = dir.path().join("assets");
    let p = write(
        dir.path(),
        "m.toml",
        &format!("[scene]\nsearch_paths = [\"lib\"]\n{CAMERA}[[objects]]\nobj = \"models/gone.obj\"\n"),
    );
    let e = err_of(load(&p, &LoadOptions { overrides: vec![], asset_paths: vec![extra.clone()] }));
    let SceneError::AssetNotFound { tried, .. } = &e else { panic!("{e:?}") };
    assert_eq!(
        tried,
        &vec![
            dir.path().join("models/gone.obj"),
            extra.join("models/gone.obj"),
            dir.path().join("lib").join("models/gone.obj"),
        ]
    );
    let ps = |p: PathBuf| p.display().to_string();
    assert_msg(
        &e,
        &[
            "m.toml",
            "models/gone.obj",
            &ps(dir.path().join("models/gone.obj")),
            &ps(extra.join("models/gone.obj")),
            &ps(dir.path().join("lib/models/gone.obj")),
        ],
    );
}

#[test]
fn asset_paths_and_search_paths_resolve() {
    let dir = tempfile::tempdir().unwrap();
    write(&dir.path().join("assets"), "a.obj", TRI_OBJ);
    write(&dir.path().join("lib"), "b.obj", TRI_OBJ);
    let p = write(
        &dir.path().join("scenes"),
        "s.toml",
        &format!(
            "[scene]\nsearch_paths = [\"../lib\"]\n{CAMERA}[[objects]]\nobj = \"a.obj\"\n[[objects]]\nobj = \"b.obj\"\n"
        ),
    );
    let s = load(&p, &LoadOptions { overrides: vec![], asset_paths: vec![dir.path().join("assets")] }).unwrap();
    assert_eq!(s.objects.len(), 2);
    assert_eq!(s.objects[0].name, "a");
    assert_eq!(s.objects[1].name, "b");
    assert_eq!(s.name, "s");
}

// Long: a table of bad scene files, each with the words its error must contain.
#[test]
fn invalid_values() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "tri.obj", TRI_OBJ);
    let cases: &[(&str, &[&str])] = &[
        (
            "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 0\n",
            &["camera.fov_y", "(0, 180)"],
        ),
        (
            "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 180\n",
            &["camera.fov_y"],
        ),
        (
            "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 5]\n",
            &["camera.target", "same point"],
        ),
        (
            "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nnear = 1\nfar = 0.5\n",
            &["camera.far"],
        ),
        (
            "[camera]\nposition = [0, 5, 0]\ntarget = [0, 0, 0]\n",
            &["camera.up", "parallel"],
        ),
        (&format!("{CAMERA}[render]\nwidth = 0\n"), &["render.width", "1..=16384"]),
        (&format!("{CAMERA}[render]\nheight = 20000\n"), &["render.height"]),
        (&format!("{CAMERA}[render]\nshadow_map_size = 8\n"), &["render.shadow_map_size"]),
        (
            &format!("{CAMERA}[scene]\nbounds = {{ min = [1, 1, 1], max = [0, 2, 2] }}\n"),
            &["scene.bounds", "smaller"],
        ),
        (
            &format!(
                "{CAMERA}[[lights]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = [1, 1, 1]\ninner_angle = 40\nouter_angle = 30\n"
            ),
            &["lights.0.inner_angle", "outer_angle = 30"],
        ),
        (
            &format!(
                "{CAMERA}[[lights]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = [1, 1, 1]\nouter_angle = 95\n"
            ),
            &["lights.0.outer_angle", "[0, 90)"],
        ),
        (
            &format!("{CAMERA}[[lights]]\ntype = \"area\"\nposition = [0, 1, 0]\n"),
            &["lights.0.type", "unknown light type `area`", "point, directional, spot"],
        ),
        (
            &format!(
                "{CAMERA}[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\nirradiance = [1, 1, 1]\n"
            ),
            &["lights.0.irradiance", "does not apply to point lights"],
        ),
        (
            &format!("{CAMERA}[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\n"),
            &["lights.0.intensity", "needs"],
        ),
        (
            &format!(
                "{CAMERA}[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, -1, 1]\n"
            ),
            &["lights.0.intensity", ">= 0"],
        ),
        (
            &format!(
                "{CAMERA}[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, nan, 1]\n"
            ),
            &["lights.0.intensity", "not finite"],
        ),
        (
            &format!(
                "{CAMERA}[[lights]]\ntype = \"directional\"\ndirection = [0, 0, 0]\nirradiance = [1, 1, 1]\n"
            ),
            &["lights.0.direction", "zero"],
        ),
        (
            &format!("{CAMERA}[[objects]]\nobj = \"tri.obj\"\nmaterial = \"chrome\"\n"),
            &["objects.0.material", "unknown material `chrome`"],
        ),
        (
            &format!(
                "{CAMERA}[[materials]]\nname = \"w\"\n[[objects]]\nobj = \"tri.obj\"\nmaterials = {{ floor = \"nope\" }}\n"
            ),
            &["objects.0.materials.floor", "unknown material `nope`", "defined: w"],
        ),
        (
            &format!(
                "{CAMERA}[[materials]]\nname = \"w\"\n[[objects]]\nobj = \"tri.obj\"\nmaterials = {{ floor = \"w\" }}\n"
            ),
            &["objects.0.materials.floor", "no group `floor`", "unnamed_object"],
        ),
        (
            &format!("{CAMERA}[[materials]]\nname = \"w\"\n[[materials]]\nname = \"w\"\n"),
            &["materials.1.name", "defined twice"],
        ),
        (
            &format!("{CAMERA}[[materials]]\nname = \"w\"\nalbedo = [0.5, -0.1, 0]\n"),
            &["materials.0.albedo", ">= 0"],
        ),
        (
            &format!("{CAMERA}[[objects]]\nobj = \"tri.obj\"\nscale = 0\n"),
            &["objects.0.scale", "zero"],
        ),
        (
            &format!(
                "{CAMERA}[[objects]]\nobj = \"tri.obj\"\nmotion = {{ degrees_per_second = 10 }}\n"
            ),
            &["objects.0.dynamic", "dynamic = true"],
        ),
        (
            &format!(
                "{CAMERA}[[objects]]\nobj = \"tri.obj\"\nkeyframes = [{{ time = 0 }}]\n"
            ),
            &["objects.0.dynamic", "dynamic = true"],
        ),
        (
            &format!(
                "{CAMERA}[[objects]]\nobj = \"tri.obj\"\ndynamic = true\nmotion = {{ period = 1 }}\nkeyframes = [{{ time = 0 }}]\n"
            ),
            &["objects.0", "not both"],
        ),
        (
            &format!(
                "{CAMERA}[[objects]]\nobj = \"tri.obj\"\ndynamic = true\nkeyframes = [{{ time = 1 }}, {{ time = 1 }}]\n"
            ),
            &["objects.0.keyframes.1.time", "must increase"],
        ),
        (
            &format!(
                "{CAMERA}[[objects]]\nobj = \"tri.obj\"\ndynamic = true\nmotion = {{ axis = [0, 0, 0], degrees_per_second = 5 }}\n"
            ),
            &["objects.0.motion.axis"],
        ),
    ];
    for (k, (toml_text, parts)) in cases.iter().enumerate() {
        let p = write(d, &format!("case{k}.toml"), toml_text);
        let e = err_of(load_default(&p));
        assert!(matches!(e, SceneError::InvalidValue { .. }), "case {k}: {e:?}");
        let mut all = vec![format!("case{k}.toml")];
        all.extend(parts.iter().map(|s| s.to_string()));
        assert_msg(&e, &all.iter().map(String::as_str).collect::<Vec<_>>());
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ / MTL / texture errors
// ---------------------------------------------------------------------------------------------

fn obj_case(obj: &str) -> SceneError {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.obj", obj);
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    err_of(load_default(&p))
}

#[test]
fn malformed_obj() {
    let e = obj_case("v 0 0 0\nv 1 2 abc\n");
    assert!(matches!(e, SceneError::Obj { .. }));
    assert_msg(&e, &["m.obj", "line 2", "`abc` is not a number"]);
    assert_msg(&obj_case("v 0 0\n"), &["m.obj", "line 1", "3 coordinates"]);
    assert_msg(&obj_case("v 0 0 0 0\n"), &["m.obj", "line 1", "w"]);
    assert_msg(&obj_case("v 0 0 0\nvn 0 x 0\n"), &["m.obj", "line 2", "normal"]);
    assert_msg(&obj_case("v 0 0 0\nvt x\n"), &["m.obj", "line 2", "texture coordinate"]);
    assert_msg(&obj_case("v 0 0 0\nv 1 0 0\nf 1 2\n"), &["m.obj", "line 3", "at least 3"]);
    assert_msg(&obj_case(&format!("{TRI_OBJ}f 1/2/3/4 2 3\n")), &["m.obj", "line 5"]);
    assert_msg(&obj_case(&format!("{TRI_OBJ}f a 2 3\n")), &["m.obj", "line 5", "integer"]);
}

#[test]
fn face_index_out_of_range() {
    let e = obj_case("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    assert!(matches!(e, SceneError::Obj { .. }));
    assert_msg(&e, &["m.obj", "line 4", "vertex 4", "only 3"]);
    assert_msg(&obj_case(&format!("{TRI_OBJ}f -1 -2 -4\n")), &["m.obj", "line 5", "-4"]);
    assert_msg(&obj_case(&format!("{TRI_OBJ}f 0 1 2\n")), &["m.obj", "line 5", "index 0"]);
    assert_msg(&obj_case(&format!("{TRI_OBJ}vn 0 0 1\nf 1//1 2//2 3//1\n")), &["m.obj", "line 6", "normal 2"]);
    assert_msg(&obj_case(&format!("{TRI_OBJ}f 1/1 2/1 3/1\n")), &["m.obj", "line 5", "texture coordinate 1"]);
    assert_msg(&obj_case(&format!("{TRI_OBJ}f 99999999999999999999 1 2\n")), &["m.obj", "line 5"]);
}

#[test]
fn nan_coordinates_rejected() {
    let e = obj_case("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    assert_msg(&e, &["m.obj", "line 2", "not a finite number"]);
    assert_msg(&obj_case("v 0 0 inf\n"), &["m.obj", "line 1", "finite"]);
    assert_msg(&obj_case("v 0 0 1e39\n"), &["m.obj", "line 1", "finite"]);
    assert_msg(&obj_case("v 0 0 0\nvn NaN 0 0\n"), &["m.obj", "line 2", "finite"]);
}

#[test]
fn missing_mtl_is_a_warning_and_the_default_material() {
    // As other loaders do: the model still loads, white.
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.obj", &format!("mtllib nothere.mtl\n{TRI_OBJ}usemtl red\nf 1 2 3\n"));
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    let s = load_default(&p).unwrap();
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!((m.name.as_str(), m.albedo), ("default", Vec3::splat(0.8)));
    // A library that exists but is a directory is an error that says so.
    std::fs::create_dir(dir.path().join("nothere.mtl")).unwrap();
    assert_msg(&err_of(load_default(&p)), &["nothere.mtl", "a directory"]);
}

/// Polygons as one face each: a concave face keeps its area (no fan over the notch), a
/// non-planar one gives n - 2 triangles facing its way.
#[test]
fn polygon_faces_are_ear_clipped() {
    // A 66-vertex concave ring (radius alternating 1 and 0.3).
    let mut obj = String::new();
    for i in 0..66 {
        let a = i as f64 / 66.0 * std::f64::consts::TAU;
        let r = if i % 2 == 0 { 1.0 } else { 0.3 };
        obj.push_str(&format!("v {} {} 0\n", r * a.cos(), r * a.sin()));
    }
    obj.push_str(&format!("f {}\n", (1..=66).map(|i| i.to_string()).collect::<Vec<_>>().join(" ")));
    // A twisted quad.
    obj.push_str("v 2 0 0\nv 3 0 0.1\nv 3 1 0\nv 2 1 0.1\nf 67 68 69 70\n");
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.obj", &obj);
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    let s = load_default(&p).unwrap();
    let m = &s.meshes[0];
    assert_eq!(m.indices.len(), 3 * (64 + 2));
    let tri = |t: &[u32]| {
        let p = |k: usize| m.positions[t[k] as usize].as_dvec3();
        (p(1) - p(0)).cross(p(2) - p(0)) / 2.0
    };
    let ring: Vec<_> = m.indices.chunks(3).take(64).map(tri).collect();
    let area: f64 = ring.iter().map(|n| n.length()).sum();
    let shoelace: f64 = (0..66)
        .map(|i| {
            let (a, b) = (i as f64 / 66.0 * std::f64::consts::TAU, (i + 1) as f64 / 66.0 * std::f64::consts::TAU);
            let (ra, rb) = (if i % 2 == 0 { 1.0 } else { 0.3 }, if (i + 1) % 2 == 0 { 1.0 } else { 0.3 });
            ra * rb * (b - a).sin() / 2.0
        })
        .sum();
    assert!((area - shoelace).abs() < 1e-4, "area {area} against {shoelace} (a fan covers about 3.2)");
    assert!(ring.iter().all(|n| n.z > 0.0), "no inverted triangle");
    assert!(m.indices.chunks(3).skip(64).map(tri).all(|n| n.z > 0.0), "the twisted quad faces +z");
}

/// Forms that other OBJ readers accept: inline comments, CR-only line endings, `\` line
/// continuations, one-value `vt`, an empty `usemtl`, upper-case keywords.
#[test]
fn obj_forms_other_tools_accept() {
    let load = |obj: &[u8]| {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.obj"), obj).unwrap();
        let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
        load_default(&p)
    };
    let tri = |s: &Scene| (s.meshes.len(), s.meshes.first().map(|m| m.indices.len()));
    let s = load(b"v 0 0 0 # origin\nv 1 0 0 #x\nv 0 1 0\t# y\nf 1 2 3 # one face\n").unwrap();
    assert_eq!(tri(&s), (1, Some(3)));
    assert_eq!(s.meshes[0].positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
    assert_eq!(tri(&load(b"v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r").unwrap()), (1, Some(3)));
    assert_eq!(tri(&load(b"v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n").unwrap()), (1, Some(3)));
    let s = load(b"v 0 \\\n 0 0\nv 1 0 0\nv 0 1 0\nf 1 \\\n2 3\nv 5 5 x\n").unwrap_err();
    // Line numbers still count physical lines after a continuation.
    assert_msg(&s, &["m.obj", "line 7", "`x` is not a number"]);
    let s = load(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5\nf 1/1 2/1 3/1\n").unwrap();
    assert_eq!(s.meshes[0].uvs[0], glam::Vec2::new(0.5, 1.0), "v is 0 (flipped to 1 in image space)");
    assert_eq!(tri(&load(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl\nf 1 2 3\n").unwrap()), (1, Some(3)));
    // A comment after a name, after a tab; a `#` inside a name stays.
    let s = load(b"o a#1\t# the first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_eq!(s.meshes[0].name, "a#1");
    let s = load(b"V 0 0 0\nV 1 0 0\nV 0 1 0\nF 1 2 3\n").unwrap();
    assert_eq!(tri(&s), (1, Some(3)));
}

/// A text file that is no OBJ at all is refused, not rendered black.
#[test]
fn a_file_without_obj_statements_is_refused() {
    let e = obj_case("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n");
    assert!(matches!(e, SceneError::Obj { .. }), "{e:?}");
    assert_msg(&e, &["m.obj", "no OBJ statement", "Wavefront OBJ"]);
    assert_msg(&obj_case("# only a comment\n"), &["m.obj", "no OBJ statement"]);
}

/// Paths that exist but are no regular file are named for what they are, never "not found",
/// and nothing blocks or reads without end.
#[cfg(unix)]
#[test]
fn directories_fifos_devices_and_link_loops_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = |obj: &str| write(d, "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"{obj}\"\n"));
    std::fs::create_dir(d.join("dir.obj")).unwrap();
    assert_msg(&err_of(load_default(&scene("dir.obj"))), &["dir.obj", "a directory"]);
    let fifo = d.join("fifo.obj");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    assert_msg(&err_of(load_default(&scene("fifo.obj"))), &["fifo.obj", "FIFO"]);
    std::os::unix::fs::symlink(d.join("loop.obj"), d.join("loop.obj")).unwrap();
    assert_msg(&err_of(load_default(&scene("loop.obj"))), &["loop.obj", "symbolic link"]);
    assert_msg(&err_of(load_default(&scene("/dev/null"))), &["/dev/null", "a device"]);
    // The scene file itself.
    for p in ["/dev/zero", "/dev/null"] {
        assert_msg(&err_of(load_default(Path::new(p))), &[p, "a device"]);
    }
    assert_msg(&err_of(load_default(&fifo)), &["fifo.obj", "FIFO"]);
    assert_msg(&err_of(load_default(d)), &["a directory"]);
}

#[test]
fn malformed_mtl() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.obj", &format!("mtllib m.mtl\nusemtl a\n{TRI_OBJ}"));
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    for (mtl, parts) in [
        ("newmtl a\nKd 0.5 0.5\n", vec!["m.mtl", "line 2", "Kd"]),
        ("newmtl a\nKd 0.5 x 1\n", vec!["m.mtl", "line 2", "`x`"]),
        ("newmtl a\nKs -1 0 0\n", vec!["m.mtl", "line 2", "negative"]),
        ("newmtl a\nNs\n", vec!["m.mtl", "line 2", "Ns"]),
        ("newmtl a\nKe nan 0 0\n", vec!["m.mtl", "line 2", "finite"]),
        ("newmtl\n", vec!["m.mtl", "line 1", "newmtl"]),
    ] {
        write(dir.path(), "m.mtl", mtl);
        let e = err_of(load_default(&p));
        assert!(matches!(e, SceneError::Mtl { .. }), "{e:?}");
        assert_msg(&e, &parts);
    }
}

#[test]
fn missing_texture() {
    // An MTL texture that is not found is a warning: the material keeps its Kd colour.
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.obj", &format!("mtllib m.mtl\nusemtl a\n{TRI_OBJ}"));
    write(dir.path(), "m.mtl", "newmtl a\nmap_Kd tex/gone.png\nKd 1 0.5 0.25\n");
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    let s = load_default(&p).unwrap();
    assert!(s.textures.is_empty());
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!((m.name.as_str(), m.albedo, m.albedo_texture), ("a", Vec3::new(1.0, 0.5, 0.25), None));

    // A directory where the texture should be is an error.
    std::fs::create_dir_all(dir.path().join("tex/gone.png")).unwrap();
    let e = err_of(load_default(&p));
    assert!(matches!(e, SceneError::Mtl { .. }), "{e:?}");
    assert_msg(&e, &["m.mtl", "line 2", "gone.png", "not a file"]);

    // A scene-file texture goes through asset resolution and stays an error.
    let p =
        write(dir.path(), "s2.toml", &format!("{CAMERA}[[materials]]\nname = \"t\"\nalbedo_texture = \"none.png\"\n"));
    let e = err_of(load_default(&p));
    assert!(matches!(e, SceneError::AssetNotFound { .. }), "{e:?}");
    assert_msg(&e, &["s2.toml", "none.png"]);
}

#[test]
fn corrupt_texture() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "bad.png", "this is not a png at all \x01\x02\x03");
    write(dir.path(), "m.obj", &format!("mtllib m.mtl\nusemtl a\n{TRI_OBJ}"));
    write(dir.path(), "m.mtl", "newmtl a\nmap_Kd bad.png\n");
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    let e = err_of(load_default(&p));
    assert!(matches!(e, SceneError::Texture { .. }), "{e:?}");
    assert_msg(&e, &["bad.png", "decode", "m.mtl line 2"]);

    let p =
        write(dir.path(), "s2.toml", &format!("{CAMERA}[[materials]]\nname = \"t\"\nalbedo_texture = \"bad.png\"\n"));
    let e = err_of(load_default(&p));
    assert_msg(&e, &["bad.png", "decode", "s2.toml"]);
}

#[test]
fn texture_loads() {
    let dir = tempfile::tempdir().unwrap();
    let px: Vec<u8> = vec![
        255, 0, 0, 255, 0, 255, 0, 255, //
        0, 0, 255, 255, 255, 255, 255, 128,
    ];
    image::RgbaImage::from_raw(2, 2, px.clone()).unwrap().save(dir.path().join("t.png")).unwrap();
    write(
        dir.path(),
        "m.obj",
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3\n",
    );
    write(dir.path(), "m.mtl", "newmtl a\nKd 1 1 1\nmap_Kd -s 1 1 1 t.png\n");
    let p = write(
        dir.path(),
        "s.toml",
        &format!("{CAMERA}[[materials]]\nname = \"same\"\nalbedo_texture = \"t.png\"\n[[objects]]\nobj = \"m.obj\"\n"),
    );
    let s = load_default(&p).unwrap();
    assert_eq!(s.textures.len(), 1, "the same file is decoded once");
    let t = &s.textures[0];
    assert_eq!((t.width, t.height), (2, 2));
    assert_eq!(t.rgba8, px);
    let m = &s.materials[s.meshes[0].material as usize];
    assert_eq!(m.name, "a");
    assert_eq!(m.albedo_texture, Some(0));
    assert_eq!(s.materials[0].albedo_texture, Some(0));
    // UVs are flipped to a top-left origin.
    assert_eq!(s.meshes[0].uvs[0], Vec2::new(0.0, 1.0));
    assert_eq!(s.meshes[0].uvs[2], Vec2::new(0.0, 0.0));
}

#[test]
fn material_maps_load_by_kind() {
    // Crytek's quirks: backslash paths, a greyscale RGB mask, a `_ddn` normal map named as a
    // bump map (DirectX convention), a colour texture as a bump map, `-bm` before the name.
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("tex")).unwrap();
    let save = |name: &str, px: [u8; 4]| {
        image::RgbaImage::from_raw(1, 1, px.to_vec()).unwrap().save(dir.path().join("tex").join(name)).unwrap();
    };
    save("mask.png", [200, 200, 200, 255]);
    save("ddn.png", [100, 60, 240, 255]);
    save("bricks.png", [150, 120, 90, 255]);
    write(dir.path(), "m.obj", &format!("mtllib m.mtl\nusemtl leaf\n{TRI_OBJ}usemtl wall\n{TRI_OBJ}"));
    write(
        dir.path(),
        "m.mtl",
        "newmtl leaf\nmap_d tex\\mask.png\nmap_bump tex\\ddn.png\nnewmtl wall\nbump -bm 0.25 tex\\bricks.png\n",
    );
    let scene = |convention: &str| {
        let p = write(
            dir.path(),
            "s.toml",
            &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\nnormal_maps = \"{convention}\"\n"),
        );
        load_default(&p).unwrap()
    };
    let s = scene("directx");
    let by_name = |n: &str| s.materials.iter().find(|m| m.name == n).unwrap().clone();
    let (leaf, wall) = (by_name("leaf"), by_name("wall"));
    let tex = |i: Option<u32>| &s.textures[i.unwrap() as usize];
    assert_eq!((tex(leaf.mask_texture).usage, tex(leaf.mask_texture).rgba8.clone()), (TextureUse::Mask, vec![200; 4]));
    // The DirectX map is stored in the OpenGL convention: green turned around.
    assert_eq!(
        (tex(leaf.normal_texture).usage, tex(leaf.normal_texture).rgba8.clone()),
        (TextureUse::Normal, vec![100, 195, 240, 255])
    );
    assert_eq!(
        (tex(wall.normal_texture).usage, tex(wall.normal_texture).rgba8.clone()),
        (TextureUse::Height, vec![120; 4])
    );
    assert_eq!((wall.relief, leaf.relief), (Relief::Tile(0.25), Relief::Tile(1.0)));
    assert_eq!(
        scene("opengl").textures.iter().find(|t| t.usage == TextureUse::Normal).unwrap().rgba8,
        [100, 60, 240, 255]
    );

    // Scene-file materials: both a normal and a bump map is refused, naming the key.
    let p = write(
        dir.path(),
        "s2.toml",
        &format!("{CAMERA}[[materials]]\nname = \"t\"\nnormal_texture = \"tex/ddn.png\"\nbump_texture = \"tex/bricks.png\"\n"),
    );
    assert_msg(&err_of(load_default(&p)), &["s2.toml", "materials.0.bump_texture", "not both"]);
    // A relief in scene units or in times the default, not both; neither is the default.
    let bump = |extra: &str| {
        let text = format!("{CAMERA}[[materials]]\nname = \"t\"\nbump_texture = \"tex/bricks.png\"\n{extra}");
        load_default(&write(dir.path(), "s3.toml", &text))
    };
    assert_eq!(bump("").unwrap().materials[0].relief, Relief::Tile(1.0));
    assert_eq!(bump("bump_scale = 0.02\n").unwrap().materials[0].relief, Relief::Units(0.02));
    assert_eq!(bump("bump_relief = 3\n").unwrap().materials[0].relief, Relief::Tile(3.0));
    assert_msg(
        &err_of(bump("bump_scale = 0.02\nbump_relief = 3\n")),
        &["s3.toml", "materials.0.bump_relief", "not both"],
    );
}

#[test]
fn supersampling_and_cascades_are_range_checked() {
    let dir = tempfile::tempdir().unwrap();
    for (line, key) in [
        ("supersample = 0", "render.supersample"),
        ("supersample = 5", "render.supersample"),
        ("shadow_cascades = 5", "render.shadow_cascades"),
        ("width = 8192\nsupersample = 3", "render.supersample"),
    ] {
        let p = write(dir.path(), "s.toml", &format!("{CAMERA}[render]\n{line}\n"));
        assert_msg(&err_of(load_default(&p)), &["s.toml", key]);
    }
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[render]\nsupersample = 2\nwidth = 100\nheight = 50\n"));
    assert_eq!(load_default(&p).unwrap().settings.internal_size(), (200, 100));
}

// ---------------------------------------------------------------------------------------------
// Geometry and materials
// ---------------------------------------------------------------------------------------------

#[test]
fn material_precedence() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "m.obj",
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\ng a\nusemtl ma\nf 1 2 3\ng b\nusemtl mb\nf 1 2 3\ng c\nusemtl undefined\nf 1 2 3\n",
    );
    write(
        dir.path(),
        "m.mtl",
        "newmtl ma\nKd 0.1 0.2 0.3\nKs 0.5 0.5 0.5\nNs 20\nKe 1 2 3 # glow\nnewmtl mb\nKd 0.4\n",
    );
    let base =
        format!("{CAMERA}[[materials]]\nname = \"s1\"\n[[materials]]\nname = \"s2\"\n[[objects]]\nobj = \"m.obj\"\n");
    // MTL materials, and the default for an unknown usemtl.
    let p = write(dir.path(), "s.toml", &base);
    let s = load_default(&p).unwrap();
    let mat = |s: &Scene, g: &str| s.materials[mesh(s, g).material as usize].clone();
    let ma = mat(&s, "a");
    assert_eq!(ma.name, "ma");
    assert_eq!(ma.albedo, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(ma.specular, Vec3::splat(0.5));
    assert_eq!(ma.shininess, 20.0);
    assert_eq!(ma.emission, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(mat(&s, "b").albedo, Vec3::splat(0.4));
    assert_eq!(mat(&s, "c").name, "default");
    assert_eq!(mat(&s, "c").albedo, Vec3::splat(0.8));
    // Object-wide beats MTL; per-group beats object-wide.
    let p = write(dir.path(), "s2.toml", &format!("{base}material = \"s1\"\nmaterials = {{ b = \"s2\" }}\n"));
    let s = load_default(&p).unwrap();
    assert_eq!(mat(&s, "a").name, "s1");
    assert_eq!(mat(&s, "b").name, "s2");
    assert_eq!(mat(&s, "c").name, "s1");
}

#[test]
fn no_mtllib_uses_default_material() {
    let dir = tempfile::tempdir().unwrap();
    let p = tri_scene(dir.path(), "");
    let s = load_default(&p).unwrap();
    assert_eq!(s.materials.len(), 1);
    assert_eq!(s.materials[0].name, "default");
    assert_eq!(s.materials[0].albedo, Vec3::splat(0.8));
    // No normals in the file: generated, facing +z for this CCW triangle; zero UVs.
    assert!(s.meshes[0].normals.iter().all(|n| *n == Vec3::Z));
    assert!(s.meshes[0].uvs.iter().all(|u| *u == Vec2::ZERO));
    assert_eq!(s.objects[0].name, "tri");
}

#[test]
fn generated_normals_respect_creases_and_smooth_gentle_angles() {
    let dir = tempfile::tempdir().unwrap();
    // A cube with 8 shared corners and no normals: every face must get its own flat normal.
    let cube = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
                f 1 4 3 2\nf 5 6 7 8\nf 1 5 8 4\nf 2 3 7 6\nf 4 8 7 3\nf 1 2 6 5\n";
    write(dir.path(), "cube.obj", cube);
    // Two faces meeting at a gentle 20 degree fold share a smoothed normal along the fold.
    let t = 20f32.to_radians().tan();
    write(dir.path(), "fold.obj", &format!("v 0 0 0\nv 0 0 1\nv 1 0 0\nv -1 {t} 0\nf 1 2 3\nf 1 4 2\n"));
    // A degenerate triangle (all points on a line) still gets unit normals.
    write(dir.path(), "line.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    let p = write(
        dir.path(),
        "s.toml",
        &format!(
            "{CAMERA}[[objects]]\nobj = \"cube.obj\"\n[[objects]]\nobj = \"fold.obj\"\n[[objects]]\nobj = \"line.obj\"\n"
        ),
    );
    let s = load_default(&p).unwrap();
    let c = &s.meshes[s.objects[0].meshes[0] as usize];
    assert_eq!(c.positions.len(), 24);
    for t in c.indices.chunks(3) {
        let (a, b, d) = (c.positions[t[0] as usize], c.positions[t[1] as usize], c.positions[t[2] as usize]);
        let f = (b - a).cross(d - a).normalize();
        for &i in t {
            assert!(approx(c.normals[i as usize], f, 1e-6));
            // Outward for this cube.
            assert!(c.normals[i as usize].dot(c.positions[i as usize]) > 0.0);
        }
    }
    let f = &s.meshes[s.objects[1].meshes[0] as usize];
    assert_eq!(f.positions.len(), 4);
    let shared = f.positions.iter().position(|p| *p == Vec3::ZERO).unwrap();
    let n = f.normals[shared];
    assert!(n.y > 0.95 && n.x > 0.05, "{n}");
    let l = &s.meshes[s.objects[2].meshes[0] as usize];
    assert!(l.normals.iter().all(|n| *n == Vec3::Y));
}

#[test]
fn provided_normals_are_normalised_and_repaired() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "n.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 2\nvn 0 0 0\nf 1//1 2//1 3//2\n");
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"n.obj\"\n"));
    let s = load_default(&p).unwrap();
    assert!(s.meshes[0].normals.iter().all(|n| *n == Vec3::Z));
}

/// Every normal of every mesh is finite and of unit length.
fn assert_unit_normals(s: &Scene) {
    for m in &s.meshes {
        assert_eq!(m.normals.len(), m.positions.len(), "{}", m.name);
        for n in &m.normals {
            assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-5, "mesh {}: normal {n}", m.name);
        }
        assert!(m.positions.iter().all(|p| p.is_finite()));
    }
}

#[test]
fn zero_length_normals_and_degenerate_triangles_give_unit_normals() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        // Zero normals on a proper triangle: the face normal (+z).
        ("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n", Some(Vec3::Z)),
        // A denormal normal is as good as zero (it cannot be normalised in f32).
        ("tiny.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1e-45 0 0\nf 1//1 2//1 3//1\n", None),
        // Normalised in f32 this one would have length 0.944 (its square is denormal).
        ("denormal.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 5e-23 0 0\nf 1//1 2//1 3//1\n", Some(Vec3::X)),
        // Zero normals on degenerate triangles (collinear, one repeated point): +Y fallback.
        ("degen.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nvn 0 0 0\nf 1//1 2//1 3//1\nf 1//1 1//1 1//1\n", Some(Vec3::Y)),
        // Generated normals of degenerate triangles, mixed with a proper one.
        ("gen.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 1 1\nf 1 2 4\nf 3 3 2\n", None),
        // Huge but finite coordinates: edges overflow f32, normals must not.
        ("huge.obj", "v 0 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\n", Some(Vec3::Z)),
        // Tiny triangles whose f32 cross product underflows to zero.
        ("small.obj", "v 0 0 0\nv 1e-30 0 0\nv 0 1e-30 0\nf 1 2 3\n", Some(Vec3::Z)),
        ("small2.obj", "v 0 0 0\nv 1e-30 0 0\nv 0 1e-30 0\nvn 0 0 0\nf 1//1 2//1 3//1\n", Some(Vec3::Z)),
    ];
    let mut toml = CAMERA.to_owned();
    for (name, obj, _) in &cases {
        write(d, name, obj);
        toml.push_str(&format!("[[objects]]\nobj = \"{name}\"\n"));
    }
    let s = load_default(&write(d, "s.toml", &toml)).unwrap();
    assert_unit_normals(&s);
    for (k, (name, _, want)) in cases.iter().enumerate() {
        if let Some(w) = want {
            for &mi in &s.objects[k].meshes {
                let m = &s.meshes[mi as usize];
                assert!(m.normals.iter().all(|n| approx(*n, *w, 1e-6)), "{name}: {:?}", m.normals);
            }
        }
    }
}

#[test]
fn binary_empty_and_wrongly_encoded_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let png: &[u8] = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR";
    let utf16: Vec<u8> = b"\xff\xfe".iter().copied().chain("v 0 0 0\n".bytes().flat_map(|b| [b, 0])).collect();
    let cases: Vec<(&[u8], Vec<&str>)> = vec![
        (b"", vec!["empty (0 bytes)"]),
        (b"  \n\t\r\n", vec!["empty (only white space)"]),
        (png, vec!["PNG image"]),
        (b"v 0 0 0\nv 1 0\x00 0\n", vec!["line 2", "column 6", "NUL"]),
    ];
    // The same checks for each kind of file: OBJ, MTL and the scene file itself.
    write(d, "ok.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let ok_scene = write(d, "ok.toml", &format!("{CAMERA}[[objects]]\nobj = \"ok.obj\"\n"));
    let obj_scene = write(d, "obj.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    for (bytes, parts) in &cases {
        std::fs::write(d.join("m.obj"), bytes).unwrap();
        let e = err_of(load_default(&obj_scene));
        assert!(matches!(e, SceneError::Obj { .. }), "{e:?}");
        assert_msg(&e, &[&["m.obj"], parts.as_slice()].concat());

        std::fs::write(d.join("m.mtl"), bytes).unwrap();
        let e = err_of(load_default(&ok_scene));
        assert!(matches!(e, SceneError::Mtl { .. }), "{e:?}");
        assert_msg(&e, &[&["m.mtl"], parts.as_slice()].concat());

        let p = d.join("bad.toml");
        std::fs::write(&p, bytes).unwrap();
        let e = err_of(load_default(&p));
        assert!(matches!(e, SceneError::Toml { .. }), "{e:?}");
        assert_msg(&e, &[&["bad.toml"], parts.as_slice()].concat());
    }
    // UTF-16 and 8-bit text are refused in a scene file (TOML is UTF-8) but read in OBJ and
    // MTL files (tests/bad_input.rs renders them).
    for (bytes, part) in [(utf16.as_slice(), "UTF-16"), (b"# ok\n# caf\xe9\n".as_slice(), "0xE9")] {
        let p = d.join("bad.toml");
        std::fs::write(&p, bytes).unwrap();
        assert_msg(&err_of(load_default(&p)), &["bad.toml", part]);
    }
    std::fs::write(d.join("m.obj"), &utf16).unwrap();
    load_default(&obj_scene).unwrap();
    std::fs::write(d.join("m.obj"), b"v 0 0 0\nv 1 0 0\nv 0 1 0\no caf\xe9\nf 1 2 3\n").unwrap();
    let s = load_default(&obj_scene).unwrap();
    assert!(s.meshes.iter().any(|m| m.name == "café"), "{:?}", s.meshes.iter().map(|m| &m.name).collect::<Vec<_>>());
    // A UTF-8 byte-order mark is fine.
    write(d, "m.mtl", "\u{feff}newmtl a\n");
    std::fs::write(d.join("bom.toml"), format!("\u{feff}{CAMERA}")).unwrap();
    load_default(&ok_scene).unwrap();
    load_default(&d.join("bom.toml")).unwrap();
}

#[test]
fn obj_statements_tobj_would_misread() {
    // Vertex colours on only some vertices (tobj alone refuses the file), tabs between the
    // keyword and a name, inline comments after texture coordinates and normals, `l` and `p`
    // elements: all load, with the statements meaning what they say.
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "m.obj",
        "mtllib\tm.mtl\nv 0 0 0\nv 1 0 0 0.5 0.5 0.5\n  v 0 2 0 2\nvt 0 0 0 # w\nvn 0 0 1 # up\nusemtl\tred one\n\
         g\tgroup a\nf 1/1/1 2/1/1 3/1/1\nl 1 2\np 1\n",
    );
    write(dir.path(), "m.mtl", "newmtl red one\nKd 1 0 0\n");
    let p = write(dir.path(), "s.toml", &format!("{CAMERA}[[objects]]\nobj = \"m.obj\"\n"));
    let s = load_default(&p).unwrap();
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.meshes[0].name, "group a");
    assert_eq!(s.meshes[0].indices.len(), 3);
    // Colours are not a w; a w divides.
    assert_eq!(s.meshes[0].positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
    assert_eq!(s.materials[s.meshes[0].material as usize].albedo, Vec3::X);
    // Statements tobj ignores silently but that are malformed are refused.
    assert_msg(&obj_case("v 0 0 0\nvt 0 0 0 0\n"), &["m.obj", "line 2", "found 4"]);
    assert_msg(&obj_case("v 0 0 0\nvn 0 0 1 nan\n"), &["m.obj", "line 2", "found 4"]);
    assert_msg(&obj_case("v 0 0 0\nvt 0 0 nan\n"), &["m.obj", "line 2", "finite"]);
}

#[test]
fn values_that_overflow_once_combined_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(d, "tri.obj", TRI_OBJ);
    let obj = "[[objects]]\nobj = \"tri.obj\"\n";
    let light = "[[lights]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\n";
    let cases: &[(String, &[&str])] = &[
        ("[camera]\nposition = [3e38, 0, 0]\ntarget = [-3e38, 0, 0]\n".into(), &["camera.target", "overflows"]),
        (
            "[camera]\nposition = [3e38, 3e38, 0]\ntarget = [3e38, 3e38, -1]\nup = [1, 1, 0]\n".into(),
            &["camera", "view or projection matrix is not finite"],
        ),
        (format!("{CAMERA}[render]\nexposure = 200\n"), &["render.exposure", "-64..=64"]),
        (format!("{CAMERA}{obj}scale = 3e38\ntranslate = [3e38, 0, 0]\n"), &["objects.0", "tri.obj", "not finite"]),
        (
            format!("{CAMERA}[render]\ntime = 1e30\n{obj}dynamic = true\nmotion = {{ velocity = [1e30, 0, 0] }}\n"),
            &["objects.0", "time 1000000000000000000000000000000", "not finite"],
        ),
        (
            format!("{CAMERA}[render]\ntime = 1e30\n{light}motion = {{ velocity = [1e30, 0, 0] }}\n"),
            &["lights.0", "not finite"],
        ),
    ];
    for (k, (text, parts)) in cases.iter().enumerate() {
        let p = write(d, &format!("case{k}.toml"), text);
        let e = err_of(load_default(&p));
        assert!(matches!(e, SceneError::InvalidValue { .. }), "case {k}: {e:?}");
        assert_msg(&e, &[&[format!("case{k}.toml").as_str()], *parts].concat());
    }
}

#[test]
fn groups_become_meshes_and_objects_transform() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "g.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\no first\nf 1 2 3\ng second\nf 2 4 3\nl 1 2 3\n");
    let p = write(
        dir.path(),
        "s.toml",
        &format!(
            "{CAMERA}[[objects]]\nname = \"thing\"\nobj = \"g.obj\"\ntranslate = [10, 0, 0]\nrotate = [0, 0, 90]\nscale = [2, 1, 1]\n"
        ),
    );
    let s = load_default(&p).unwrap();
    assert_eq!(s.meshes.len(), 2);
    assert_eq!(s.meshes[0].name, "first");
    assert_eq!(s.meshes[1].name, "second");
    assert_eq!(s.meshes[1].indices.len(), 3, "the `l` element is not a triangle");
    assert_eq!(s.objects[0].name, "thing");
    // scale x2 in x, then rotate 90 deg about z, then translate.
    let p = s.objects[0].model_matrix(0.0).transform_point3(Vec3::X);
    assert!(approx(p, Vec3::new(10.0, 2.0, 0.0), 1e-5), "{p}");
    let b = s.world_bounds(0.0);
    assert!(approx(b.min, Vec3::new(9.0, 0.0, 0.0), 1e-5), "{b:?}");
    assert!(approx(b.max, Vec3::new(10.0, 2.0, 0.0), 1e-5), "{b:?}");
}

// ---------------------------------------------------------------------------------------------
// Motion
// ---------------------------------------------------------------------------------------------

#[test]
fn parametric_motion_rotates() {
    let dir = tempfile::tempdir().unwrap();
    let p = tri_scene(
        dir.path(),
        "translate = [1, 0, 0]\ndynamic = true\nmotion = { axis = [0, 2, 0], degrees_per_second = 90 }\n\
         [[lights]]\ntype = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -2, 0]\nintensity = [1, 1, 1]\n\
         motion = { velocity = [1, 0, 0] }\n",
    );
    let s = load_default(&p).unwrap();
    assert!(s.has_dynamic());
    let o = &s.objects[0];
    let at0 = o.model_matrix(0.0).transform_point3(Vec3::ZERO);
    let at1 = o.model_matrix(1.0).transform_point3(Vec3::ZERO);
    assert!(approx(at0, Vec3::X, 1e-6));
    assert!(approx(at1, Vec3::new(0.0, 0.0, -1.0), 1e-5), "{at1}");
    match &s.lights[0].kind {
        LightKind::Spot { direction, inner_deg, outer_deg, .. } => {
            assert_eq!(*direction, Vec3::NEG_Y);
            assert_eq!((*inner_deg, *outer_deg), (20.0, 30.0));
        }
        k => panic!("{k:?}"),
    }
    match s.lights[0].at_time(2.0) {
        LightKind::Spot { position, .. } => {
            assert!(approx(position, Vec3::new(2.0, 1.0, 0.0), 1e-6))
        }
        k => panic!("{k:?}"),
    }
}

#[test]
fn keyframes_interpolate() {
    let dir = tempfile::tempdir().unwrap();
    let p = tri_scene(
        dir.path(),
        "dynamic = true\nkeyframes = [ { time = 0, translate = [0, 0, 0] }, { time = 2, translate = [2, 0, 0], rotate = [0, 90, 0], scale = 3 } ]\n",
    );
    let s = load_default(&p).unwrap();
    let o = &s.objects[0];
    let mid = o.model_matrix(1.0);
    assert!(approx(mid.transform_point3(Vec3::ZERO), Vec3::new(1.0, 0.0, 0.0), 1e-6));
    // Halfway: 45 degrees about y and scale 2.
    let x = mid.transform_vector3(Vec3::X);
    let h = std::f32::consts::FRAC_1_SQRT_2 * 2.0;
    assert!(approx(x, Vec3::new(h, 0.0, -h), 1e-5), "{x}");
    // Clamped at the ends.
    assert!(approx(o.model_matrix(5.0).transform_point3(Vec3::ZERO), Vec3::new(2.0, 0.0, 0.0), 1e-6));
    assert!(approx(o.model_matrix(-1.0).transform_point3(Vec3::ZERO), Vec3::ZERO, 1e-6));
}

#[test]
fn gi_settings_parse_override_and_validate() {
    let p = scenes_dir().join("cornell-box.toml");
    let s = with_overrides(&p, &["gi.mode=\"vct\"", "gi.voxel_resolution=64", "render.view=\"voxel-albedo\""]).unwrap();
    assert_eq!(s.settings.gi.mode, GiMode::Vct);
    assert_eq!(s.settings.gi.voxel_resolution, 64);
    assert_eq!(s.settings.view, View::VoxelAlbedo);
    let d = load_default(&p).unwrap();
    assert_eq!(d.settings.gi, GiSettings::default());
    for bad in ["gi.voxel_resolution=100", "gi.voxel_resolution=4", "gi.voxel_resolution=1024"] {
        let e = with_overrides(&p, &[bad]).unwrap_err().to_string();
        assert!(e.contains("gi.voxel_resolution") && e.contains("power of two"), "{e}");
    }
    let e = with_overrides(&p, &["gi.mode=\"path\""]).unwrap_err().to_string();
    assert!(e.contains("path"), "{e}");
    // Every cone-tracing knob is range-checked and named in the error.
    for (bad, key) in [
        ("gi.diffuse_cones=5", "gi.diffuse_cones"),
        ("gi.bounces=17", "gi.bounces"),
        ("gi.step=0", "gi.step"),
        ("gi.step=5", "gi.step"),
        ("gi.downsample=0", "gi.downsample"),
        ("gi.downsample=9", "gi.downsample"),
        ("gi.diffuse_cone_angle=180", "gi.diffuse_cone_angle"),
        ("gi.shadow_cone_angle=0", "gi.shadow_cone_angle"),
        ("gi.ao_falloff=-1", "gi.ao_falloff"),
        ("gi.max_distance=-2", "gi.max_distance"),
        ("gi.start_offset=17", "gi.start_offset"),
        ("gi.step=nan", "gi.step"),
        ("render.view_lod=-1", "render.view_lod"),
        ("render.view_direction=\"up\"", "up"),
    ] {
        let e = with_overrides(&p, &[bad]).unwrap_err().to_string();
        assert!(e.contains(key) && e.contains("cornell-box.toml"), "{bad}: {e}");
    }
    let s = with_overrides(
        &p,
        &[
            "gi.bounces=3",
            "gi.diffuse_cones=16",
            "gi.shadows=\"cone\"",
            "render.view=\"voxel-mip\"",
            "render.view_direction=\"-z\"",
        ],
    )
    .unwrap();
    assert_eq!((s.settings.gi.bounces, s.settings.gi.diffuse_cones), (3, 16));
    assert_eq!((s.settings.gi.shadows, s.settings.view_direction), (DirectShadows::Cone, ViewDirection::NegZ));
}

#[test]
fn exposure_is_ev_stops_or_auto() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let auto = load_default(&write(d, "auto.toml", &format!("{CAMERA}[render]\nexposure = \"auto\"\n"))).unwrap();
    assert!(auto.settings.exposure_auto && auto.settings.exposure == 0.0);
    let ev = load_default(&write(d, "ev.toml", &format!("{CAMERA}[render]\nexposure = -2\n"))).unwrap();
    assert!(!ev.settings.exposure_auto && ev.settings.exposure == -2.0);
    let e = err_of(load_default(&write(d, "bad.toml", &format!("{CAMERA}[render]\nexposure = \"bright\"\n"))));
    let line = format!("line {}", CAMERA.lines().count() + 2);
    assert_msg(&e, &["bad.toml", &line, "exposure", "\"auto\"", "\"bright\""]);
}

//! Helpers shared by the GPU tests: a validated lavapipe context, rendering a scene file,
//! and a CPU ray caster over the scene's own triangles for picking test points.
#![allow(dead_code)]

use dvsgi::gpu::{Context, ContextDesc};
use dvsgi::render::{FrameOutput, Renderer};
use dvsgi::scene::{self, LoadOptions, Scene};
use glam::{Vec3, Vec4};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Arc;

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Run the `dvsgi` binary from the repository root with validation on.
pub fn dvsgi(args: &[&str]) -> Output {
    dvsgi_with(args, &[])
}

/// [`dvsgi`] with extra environment variables.
pub fn dvsgi_with(args: &[&str], env: &[(&str, &str)]) -> Output {
    run_validated(Command::new(env!("CARGO_BIN_EXE_dvsgi")), args, env)
}

/// Run the `bench` binary from the repository root with validation on.
pub fn bench(args: &[&str]) -> Output {
    run_validated(Command::new(env!("CARGO_BIN_EXE_bench")), args, &[])
}

/// `program` with `args` from the repository root, validation on, extra environment.
fn run_validated(mut c: Command, args: &[&str], env: &[(&str, &str)]) -> Output {
    c.args(args).current_dir(repo()).env("DVSGI_VALIDATION", "1");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap_or_else(|e| panic!("run {:?}: {e}", c.get_program()))
}

/// A command's stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A command's stdout as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A mesh of separate triangles with flat normals (or `normal` for every vertex, which may be
/// degenerate on purpose) and zero UVs.
pub fn mesh(name: &str, tris: &[[Vec3; 3]], material: u32, normal: Option<Vec3>) -> dvsgi::scene::Mesh {
    let positions: Vec<Vec3> = tris.iter().flatten().copied().collect();
    let normals = tris
        .iter()
        .flat_map(|t| [normal.unwrap_or_else(|| (t[1] - t[0]).cross(t[2] - t[0]).normalize_or(Vec3::Y)); 3])
        .collect();
    let mut bounds = dvsgi::scene::Aabb::EMPTY;
    positions.iter().for_each(|p| bounds.grow(*p));
    dvsgi::scene::Mesh {
        name: name.into(),
        uvs: vec![glam::Vec2::ZERO; positions.len()],
        indices: (0..positions.len() as u32).collect(),
        positions,
        normals,
        material,
        bounds,
    }
}

/// The texels of an image level as f32 (RGBA32F, RGBA16F, D32 depth, RGBA8 unorm); None for
/// integer, sRGB and other formats.
pub fn float_texels(r: &mut Renderer, img: &Arc<dvsgi::gpu::Image>, level: u32) -> Option<Vec<f32>> {
    use ash::vk::Format as F;
    let f = img.desc.format;
    if !matches!(f, F::R32G32B32A32_SFLOAT | F::R16G16B16A16_SFLOAT | F::D32_SFLOAT | F::R8G8B8A8_UNORM) {
        return None;
    }
    let bytes = r.download_level(img, level).unwrap();
    Some(match f {
        F::R16G16B16A16_SFLOAT => {
            bytemuck::pod_collect_to_vec::<u8, half::f16>(&bytes).iter().map(|h| h.to_f32()).collect()
        }
        F::R8G8B8A8_UNORM => bytes.iter().map(|&b| b as f32 / 255.0).collect(),
        _ => bytemuck::pod_collect_to_vec::<u8, f32>(&bytes),
    })
}

/// Sum of radiance over the pixels `keep` selects (by index), and their number.
pub fn sum_where(out: &FrameOutput, keep: impl Fn(usize) -> bool) -> (Vec3, usize) {
    let (mut s, mut n) = (Vec3::ZERO, 0);
    for (i, p) in out.radiance.chunks_exact(4).enumerate() {
        if keep(i) {
            s += Vec3::new(p[0], p[1], p[2]);
            n += 1;
        }
    }
    (s, n)
}

/// A context with the validation layer on (tests always validate). Under
/// tools/with-split-queues.sh it must be the split device: a test run meant for the
/// cross-family path never passes on one queue by accident.
pub fn context() -> Arc<Context> {
    let ctx = Context::new(&ContextDesc { validation: true, device: None })
        .expect("a Vulkan 1.3 device (lavapipe: apt-get install mesa-vulkan-drivers)");
    if under_split_queues() {
        assert_eq!(
            ctx.topology,
            dvsgi::gpu::QueueTopology::DedicatedComputeFamily,
            "DVSGI_SPLIT_QUEUES is set but the queue-splitting layer is not active"
        );
    }
    ctx
}

/// Whether the tests run under tools/with-split-queues.sh.
pub fn under_split_queues() -> bool {
    std::env::var_os("DVSGI_SPLIT_QUEUES").is_some_and(|v| !v.is_empty() && v != "0")
}

/// Run the `dvsgi` binary under tools/with-split-queues.sh (validation on), with extra
/// environment variables.
pub fn dvsgi_split(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(repo().join("tools/with-split-queues.sh"));
    c.arg(env!("CARGO_BIN_EXE_dvsgi"));
    run_validated(c, args, env)
}

pub fn load(path: &Path, overrides: &[(&str, &str)]) -> Scene {
    scene::load(
        path,
        &LoadOptions {
            overrides: overrides.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            asset_paths: vec![],
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Render one frame and fail on any validation message.
pub fn render(ctx: &Arc<Context>, scene: Scene) -> (FrameOutput, Scene) {
    let t = scene.settings.time;
    let kept = scene.clone();
    let mut r = Renderer::new(ctx, scene).expect("renderer");
    r.render(t, true).expect("frame");
    let out = r.output();
    drop(r);
    assert_no_validation_messages(ctx);
    (out, kept)
}

pub fn assert_no_validation_messages(ctx: &Context) {
    let v = ctx.validation();
    assert_eq!((v.errors(), v.warnings()), (0, 0), "validation messages:\n{}", v.messages().join("\n"));
}

pub struct Triangle {
    pub a: Vec3,
    pub b: Vec3,
    pub c: Vec3,
    pub material: u32,
}

/// World-space triangles of the scene at time t.
pub fn triangles(scene: &Scene, t: f32) -> Vec<Triangle> {
    let mut out = Vec::new();
    for o in &scene.objects {
        let m = o.model_matrix(t);
        for &mi in &o.meshes {
            let mesh = &scene.meshes[mi as usize];
            for tri in mesh.indices.chunks_exact(3) {
                let p = |i: u32| m.transform_point3(mesh.positions[i as usize]);
                out.push(Triangle { a: p(tri[0]), b: p(tri[1]), c: p(tri[2]), material: mesh.material });
            }
        }
    }
    out
}

/// Nearest hit (distance, triangle index) of the ray o + t d, t in (tmin, tmax).
pub fn raycast(tris: &[Triangle], o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, usize)> {
    let mut best: Option<(f32, usize)> = None;
    for (i, t) in tris.iter().enumerate() {
        let e1 = t.b - t.a;
        let e2 = t.c - t.a;
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            continue;
        }
        let inv = 1.0 / det;
        let s = o - t.a;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            continue;
        }
        let q = s.cross(e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            continue;
        }
        let dist = e2.dot(q) * inv;
        if dist > tmin && dist < tmax && best.map(|b| dist < b.0).unwrap_or(true) {
            best = Some((dist, i));
        }
    }
    best
}

/// The camera ray through the centre of pixel (x, y), as the renderer defines it.
pub fn camera_ray(scene: &Scene, x: u32, y: u32) -> (Vec3, Vec3) {
    let (w, h) = (scene.settings.width as f32, scene.settings.height as f32);
    let vp = scene.camera.projection(w / h) * scene.camera.view();
    let inv = vp.inverse();
    let ndc_x = (x as f32 + 0.5) / w * 2.0 - 1.0;
    let ndc_y = (y as f32 + 0.5) / h * 2.0 - 1.0;
    let far = inv * Vec4::new(ndc_x, ndc_y, 1.0, 1.0);
    let far = far.truncate() / far.w;
    let o = scene.camera.position;
    (o, (far - o).normalize())
}

/// Pixel containing world point p.
pub fn project(scene: &Scene, p: Vec3) -> (u32, u32) {
    let (w, h) = (scene.settings.width as f32, scene.settings.height as f32);
    let vp = scene.camera.projection(w / h) * scene.camera.view();
    let c = vp * p.extend(1.0);
    let ndc = c.truncate() / c.w;
    (((ndc.x * 0.5 + 0.5) * w).floor() as u32, ((ndc.y * 0.5 + 0.5) * h).floor() as u32)
}

/// A scene of the given triangles (one object per material index), lights and camera.
pub fn scene_of(
    meshes: Vec<dvsgi::scene::Mesh>,
    materials: Vec<dvsgi::scene::Material>,
    camera: dvsgi::scene::Camera,
    lights: Vec<dvsgi::scene::Light>,
    bounds: dvsgi::scene::Aabb,
) -> Scene {
    let objects = (0..meshes.len())
        .map(|i| dvsgi::scene::Object {
            name: format!("o{i}"),
            meshes: vec![i as u32],
            transform: glam::Mat4::IDENTITY,
            dynamic: false,
            motion: dvsgi::scene::Motion::None,
        })
        .collect();
    let mut settings = dvsgi::scene::RenderSettings { width: 32, height: 32, ..Default::default() };
    settings.gi.voxel_resolution = 32;
    Scene {
        sky: None,
        path: PathBuf::from("test"),
        name: "test".into(),
        meshes,
        objects,
        materials,
        textures: vec![],
        camera,
        lights,
        settings,
        bounds: Some(bounds),
    }
}

/// Two triangles covering the axis-aligned square at `c` spanning `u` and `v` (half sizes),
/// facing `n`.
pub fn quad(c: Vec3, u: Vec3, v: Vec3, n: Vec3) -> [[Vec3; 3]; 2] {
    let (a, b, cc, d) = (c - u - v, c + u - v, c + u + v, c - u + v);
    if (b - a).cross(cc - a).dot(n) > 0.0 {
        [[a, b, cc], [a, cc, d]]
    } else {
        [[a, cc, b], [a, d, cc]]
    }
}

/// Colour bleeding in the McGuire Cornell box: white surfaces within 15 cm of the red wall
/// (x = 0.55 m, left in the image) are at least 5% redder with the indirect light than with
/// direct light alone, those near the green wall (x = 0) 5% greener, and the indirect light
/// only adds light.
pub fn assert_colour_bleeding(scene: &Scene, direct: &FrameOutput, gi: &FrameOutput, what: &str) {
    let tris = triangles(scene, 0.0);
    let w = scene.settings.width;
    let near = |i: usize, wall_x: f32| {
        let (o, d) = camera_ray(scene, i as u32 % w, i as u32 / w);
        raycast(&tris, o, d, 1e-4, 1e4).is_some_and(|(t, k)| {
            scene.materials[tris[k].material as usize].name == "white" && ((o + d * t).x - wall_x).abs() < 0.15
        })
    };
    let (d_red, n) = sum_where(direct, |i| near(i, 0.55));
    let (g_red, _) = sum_where(gi, |i| near(i, 0.55));
    assert!(n > 50, "only {n} white pixels near the red wall");
    let (d_green, _) = sum_where(direct, |i| near(i, 0.0));
    let (g_green, _) = sum_where(gi, |i| near(i, 0.0));
    let red = |v: Vec3| v.x / v.y;
    let green = |v: Vec3| v.y / v.x;
    assert!(red(g_red) > 1.05 * red(d_red), "{what}: near the red wall R/G {} vs direct {}", red(g_red), red(d_red));
    let (gg, dg) = (green(g_green), green(d_green));
    assert!(gg > 1.05 * dg, "{what}: near the green wall G/R {gg} vs direct {dg}");
    assert!(g_red.min_element() > d_red.min_element(), "{what} only adds light");
}

/// A quad with corners `p` (counter-clockwise seen from `normal`) and UVs `uv`, one mesh.
pub fn uv_quad(name: &str, p: [Vec3; 4], uv: [glam::Vec2; 4], normal: Vec3, material: u32) -> dvsgi::scene::Mesh {
    let mut bounds = dvsgi::scene::Aabb::EMPTY;
    p.iter().for_each(|q| bounds.grow(*q));
    dvsgi::scene::Mesh {
        name: name.into(),
        positions: p.to_vec(),
        normals: vec![normal; 4],
        uvs: uv.to_vec(),
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        bounds,
    }
}

/// Trace `scene` to `options.spp` with validation on; no non-finite sample.
pub fn trace_reference(scene: &Scene, options: dvsgi::reference::ReferenceOptions) -> dvsgi::reference::ReferenceImage {
    let ctx = context();
    let mut pt = dvsgi::reference::PathTracer::new(&ctx, scene, options).expect("path tracer");
    pt.run(|_, _| {}).expect("trace");
    let image = pt.image().expect("read back");
    drop(pt);
    assert_no_validation_messages(&ctx);
    assert_eq!(image.rejected, 0, "non-finite samples");
    image
}

/// The least-squares slope of y against x (log RMSE against log spp: -1/2 for an unbiased
/// estimator).
pub fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / points.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>()
}

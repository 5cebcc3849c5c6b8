//! Material maps on lavapipe with validation: alpha masks cut the G-buffer, the shadow maps,
//! the voxels and the path tracer alike; normal and height maps bend G-buffer normals as an
//! analytic height field says; supersampled textured direct light matches the reference.

mod common;

use common::*;
use dvsgi::reference::{PathTracer, ReferenceImage, ReferenceOptions};
use dvsgi::render::voxel::VoxelGrid;
use dvsgi::render::{FrameOutput, Renderer};
use dvsgi::scene::*;
use glam::{Mat4, Vec2, Vec3};
use std::f32::consts::PI;
use std::path::PathBuf;

/// A quad with corners `p` (counter-clockwise seen from `normal`) and top-down UVs `uv`.
fn quad(name: &str, p: [Vec3; 4], uv: [Vec2; 4], normal: Vec3, material: u32) -> Mesh {
    let mut bounds = Aabb::EMPTY;
    p.iter().for_each(|q| bounds.grow(*q));
    Mesh {
        name: name.into(),
        positions: p.to_vec(),
        normals: vec![normal; 4],
        uvs: uv.to_vec(),
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
        bounds,
    }
}

fn material(name: &str, albedo: Vec3) -> Material {
    Material::diffuse(name, albedo)
}

fn texture(name: &str, size: u32, usage: TextureUse, texel: impl Fn(u32, u32) -> [u8; 4]) -> Texture {
    let rgba8 = (0..size * size).flat_map(|i| texel(i % size, i / size)).collect();
    Texture { path: PathBuf::from(name), width: size, height: size, rgba8, usage }
}

fn scene(
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    textures: Vec<Texture>,
    camera: Camera,
    lights: Vec<Light>,
) -> Scene {
    Scene {
        path: PathBuf::from("maps-test"),
        name: "maps test".into(),
        objects: (0..meshes.len())
            .map(|i| Object {
                name: meshes[i].name.clone(),
                meshes: vec![i as u32],
                transform: Mat4::IDENTITY,
                dynamic: false,
                motion: Motion::None,
            })
            .collect(),
        meshes,
        materials,
        textures,
        camera,
        lights,
        settings: RenderSettings {
            width: 64,
            height: 64,
            gi: GiSettings { mode: GiMode::None, ..Default::default() },
            ..Default::default()
        },
        bounds: None,
    }
}

fn sun(direction: Vec3, irradiance: f32) -> Light {
    Light {
        name: "sun".into(),
        kind: LightKind::Directional { direction: direction.normalize(), irradiance: Vec3::splat(irradiance) },
        cast_shadows: true,
        motion: Motion::None,
    }
}

fn trace(scene: &Scene, spp: u32, jitter: bool) -> ReferenceImage {
    let ctx = context();
    let options = ReferenceOptions { spp, max_bounces: Some(0), seed: 3, batch_ms: 200.0, jitter };
    let mut pt = PathTracer::new(&ctx, scene, options).expect("path tracer");
    pt.run(|_, _| {}).expect("trace");
    let image = pt.image().expect("read back");
    drop(pt);
    assert_no_validation_messages(&ctx);
    assert_eq!(image.rejected, 0, "non-finite samples");
    image
}

/// A white floor (y = 0) and, one unit above it, a red quad whose mask is opaque on its -x
/// half only. The sun travels along (1, -1, 0), so the quad's shadow falls one unit towards
/// +x: the floor under the quad's cut-away half (x in 0..1) is in the opaque half's shadow and
/// seen through the hole; the floor at x in 1..2 lies where the cut-away half would shade it.
/// The camera looks straight down.
fn masked_quad_scene() -> Scene {
    let v = Vec3::new;
    let uv = [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];
    let floor = quad("floor", [v(-3., 0., 3.), v(3., 0., 3.), v(3., 0., -3.), v(-3., 0., -3.)], uv, Vec3::Y, 0);
    let leaf = quad("leaf", [v(-1., 1., 1.), v(1., 1., 1.), v(1., 1., -1.), v(-1., 1., -1.)], uv, Vec3::Y, 1);
    let mut red = material("leaf", v(0.8, 0.1, 0.1));
    red.mask_texture = Some(0);
    // Greyscale coverage (as Crytek's masks): opaque where u < 0.5.
    let mask = texture("mask", 64, TextureUse::Mask, |x, _| [if x < 32 { 255 } else { 0 }; 4]);
    let camera = Camera {
        position: v(0.5, 6.0, 0.0),
        target: v(0.5, 0.0, 0.0),
        up: v(0.0, 0.0, -1.0),
        fov_y_deg: 60.0,
        near: 0.1,
        far: 20.0,
    };
    let mut s = scene(
        vec![floor, leaf],
        vec![material("floor", Vec3::splat(0.8)), red],
        vec![mask],
        camera,
        vec![sun(v(1.0, -1.0, 0.0), 3.0)],
    );
    s.bounds = Some(Aabb { min: v(-3., -3., -3.), max: v(3., 3., 3.) });
    s
}

/// Radiance at the pixel that shows world point p.
fn at(out_radiance: impl Fn(u32, u32) -> [f32; 3], scene: &Scene, p: Vec3) -> Vec3 {
    let (x, y) = project(scene, p);
    Vec3::from(out_radiance(x, y))
}

#[test]
fn an_alpha_masked_quad_is_cut_out_in_the_gbuffer_shadow_maps_and_path_tracer() {
    let s = masked_quad_scene();
    let (out, s) = render(&context(), s);
    let lit_floor = 3.0 * 0.8 / PI * (0.5f32).sqrt();
    let raster = |p: Vec3| at(|x, y| out.radiance_at(x, y), &s, p);
    let pt_image = trace(&s, 16, false);
    let reference = |p: Vec3| {
        let (x, y) = project(&s, p);
        let i = ((y * pt_image.width + x) * 3) as usize;
        Vec3::from_slice(&pt_image.mean[i..i + 3])
    };
    for (who, look) in [("rasterizer", &raster as &dyn Fn(Vec3) -> Vec3), ("path tracer", &reference)] {
        // Seen through the hole: the floor, in the opaque half's shadow (not the red quad).
        let hole = look(Vec3::new(0.5, 0.0, 0.0));
        assert!(hole.max_element() < 0.02 * lit_floor, "{who}: floor through the hole {hole}");
        // Where only the cut-away half could shade it: fully lit, as the open floor.
        let behind = look(Vec3::new(1.5, 0.0, 0.0));
        let open = look(Vec3::new(2.5, 0.0, 0.5));
        assert!((behind - Vec3::splat(lit_floor)).abs().max_element() < 0.03 * lit_floor, "{who}: {behind}");
        assert!((open - Vec3::splat(lit_floor)).abs().max_element() < 0.03 * lit_floor, "{who}: {open}");
        // The opaque half is there, red and lit.
        let leaf = look(Vec3::new(-0.5, 1.0, 0.0));
        assert!(
            (leaf.x - 3.0 * 0.8 / PI * (0.5f32).sqrt()).abs() < 0.03 * leaf.x && leaf.y < 0.2 * leaf.x,
            "{who}: {leaf}"
        );
        println!("{who}: hole {hole}, behind {behind}, open {open}, leaf {leaf}");
    }
}

#[test]
fn an_alpha_masked_quad_voxelizes_only_where_opaque() {
    let mut s = masked_quad_scene();
    s.settings.gi = GiSettings { mode: GiMode::Vct, voxel_resolution: 32, ..Default::default() };
    let grid = VoxelGrid::for_scene(&s);
    let ctx = context();
    let t = s.settings.time;
    let mut r = Renderer::new(&ctx, s).expect("renderer");
    r.render(t, true).expect("frame");
    let list = r.voxel_list().unwrap().unwrap();
    drop(r);
    assert_no_validation_messages(&ctx);
    // Voxels of the quad's layer (its plane y = 1 and the voxel below it, which it touches).
    let layer: Vec<Vec3> = list
        .entries
        .iter()
        .map(|c| grid.origin + (Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) + 0.5) * grid.voxel_size)
        .filter(|p| (p.y - 1.0).abs() < grid.voxel_size)
        .collect();
    let max_x = layer.iter().map(|p| p.x).fold(f32::MIN, f32::max);
    let min_x = layer.iter().map(|p| p.x).fold(f32::MAX, f32::min);
    println!("{} voxels at the quad's height, x from {min_x} to {max_x} (voxel {})", layer.len(), grid.voxel_size);
    // The opaque half spans x in -1..0: its voxels, and none past the cut (one voxel of slack
    // for the voxel that straddles it).
    assert!(min_x < -1.0 + grid.voxel_size, "the opaque half is missing: {min_x}");
    assert!(max_x < grid.voxel_size, "voxels past the cut, up to x = {max_x}");
    let per_row = (1.0 / grid.voxel_size).floor() as usize;
    assert!(layer.len() >= per_row * (2.0 / grid.voxel_size) as usize, "too few voxels: {}", layer.len());
}

/// Height field h(u, v) = 0.5 + 0.25 sin(4 pi u) + 0.25 sin(2 pi v) over the square
/// x, y in -1..1 (u = (x + 1) / 2, top-down v = (1 - y) / 2), displaced `scale` along +z.
fn height(u: f32, v: f32) -> f32 {
    0.5 + 0.25 * (4.0 * PI * u).sin() + 0.25 * (2.0 * PI * v).sin()
}

/// The analytic normal of z = scale h(u(x), v(y)).
fn analytic_normal(u: f32, v: f32, scale: f32) -> Vec3 {
    let hu = 0.25 * 4.0 * PI * (4.0 * PI * u).cos();
    let hv = 0.25 * 2.0 * PI * (2.0 * PI * v).cos();
    // dz/dx = scale hu du/dx = scale hu / 2; dz/dy = scale hv dv/dy = -scale hv / 2.
    Vec3::new(-scale * hu / 2.0, scale * hv / 2.0, 1.0).normalize()
}

fn bumped_square(map: Texture, scale: f32) -> Scene {
    let v = Vec3::new;
    let uv = [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];
    let square = quad("square", [v(-1., -1., 0.), v(1., -1., 0.), v(1., 1., 0.), v(-1., 1., 0.)], uv, Vec3::Z, 0);
    let mut m = material("bumped", Vec3::splat(0.8));
    m.normal_texture = Some(0);
    m.bump_scale = scale;
    let camera =
        Camera { position: v(0., 0., 3.), target: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 45.0, near: 0.1, far: 10.0 };
    scene(vec![square], vec![m], vec![map], camera, vec![sun(v(0., 0., -1.), 1.0)])
}

/// G-buffer normals of the square against the analytic field: (mean, max) angle in degrees,
/// and the largest analytic tilt seen.
fn normal_errors(s: Scene, scale: f32) -> (f32, f32, f32) {
    let ctx = context();
    let t = s.settings.time;
    let kept = s.clone();
    let mut r = Renderer::new(&ctx, s).expect("renderer");
    r.render(t, true).expect("frame");
    let normal = r.all_images().into_iter().find(|i| i.name == "gbuffer normal").unwrap();
    let texels = float_texels(&mut r, &normal, 0).unwrap();
    drop(r);
    assert_no_validation_messages(&ctx);
    let (mut sum, mut worst, mut n, mut tilt) = (0.0f32, 0.0f32, 0, 0.0f32);
    for y in 0..kept.settings.height {
        for x in 0..kept.settings.width {
            let (o, d) = camera_ray(&kept, x, y);
            let p = o + d * (-o.z / d.z);
            // Inside the square, a pixel away from its edges.
            if p.x.abs() > 0.9 || p.y.abs() > 0.9 {
                continue;
            }
            let (u, v) = ((p.x + 1.0) / 2.0, (1.0 - p.y) / 2.0);
            let want = analytic_normal(u, v, scale);
            let i = ((y * kept.settings.width + x) * 4) as usize;
            let got = Vec3::from_slice(&texels[i..i + 3]).normalize();
            let angle = got.dot(want).clamp(-1.0, 1.0).acos().to_degrees();
            sum += angle;
            worst = worst.max(angle);
            tilt = tilt.max(want.z.acos().to_degrees());
            n += 1;
        }
    }
    (sum / n as f32, worst, tilt)
}

#[test]
fn a_height_mapped_plane_has_the_normals_of_its_height_field() {
    let size = 256;
    let map = texture("height", size, TextureUse::Height, |x, y| {
        let h = height((x as f32 + 0.5) / size as f32, (y as f32 + 0.5) / size as f32);
        [(h * 255.0).round() as u8; 4]
    });
    let (mean, worst, tilt) = normal_errors(bumped_square(map, 0.25), 0.25);
    println!("height map: mean error {mean:.2} deg, worst {worst:.2} deg, largest tilt {tilt:.1} deg");
    assert!(tilt > 15.0, "the field should tilt normals noticeably: {tilt}");
    // 8-bit heights differenced one texel apart: about 1 degree of noise at the steepest.
    assert!(mean < 1.0 && worst < 3.0, "mean {mean} deg, worst {worst} deg");
}

#[test]
fn a_normal_mapped_plane_has_the_normals_of_its_height_field() {
    // The same field as a tangent-space normal map (OpenGL convention: +y is the OBJ's +v, up).
    let size = 256;
    let scale = 0.25;
    let map = texture("normals", size, TextureUse::Normal, |x, y| {
        let n = analytic_normal((x as f32 + 0.5) / size as f32, (y as f32 + 0.5) / size as f32, scale);
        let c = |v: f32| ((v * 0.5 + 0.5) * 255.0).round() as u8;
        [c(n.x), c(n.y), c(n.z), 255]
    });
    let (mean, worst, tilt) = normal_errors(bumped_square(map, 1.0), scale);
    println!("normal map: mean error {mean:.2} deg, worst {worst:.2} deg, largest tilt {tilt:.1} deg");
    assert!(tilt > 15.0, "{tilt}");
    assert!(mean < 1.0 && worst < 3.0, "mean {mean} deg, worst {worst} deg");
}

/// Rasterized and path-traced direct light on a textured, normal-mapped, alpha-masked scene,
/// both over the pixel's footprint (`render.supersample = 3` against jittered paths).
#[test]
fn supersampled_textured_direct_light_matches_the_reference() {
    let mut s = masked_quad_scene();
    // A smoothly varying colour on the floor and bumps on it, under the masked quad. (Sharp
    // texture edges would differ by up to 1/6 of their contrast: 3 x 3 ordered samples against
    // the exact box integral.)
    s.textures.push(texture("colours", 64, TextureUse::Color, |x, y| {
        let (a, b) = (2.0 * PI * x as f32 / 32.0, 2.0 * PI * y as f32 / 16.0);
        [(150.0 + 90.0 * a.sin()) as u8, (150.0 + 90.0 * b.cos()) as u8, 90, 255]
    }));
    s.textures.push(texture("bumps", 64, TextureUse::Height, |x, y| {
        let h = height(x as f32 / 64.0, y as f32 / 64.0);
        [(h * 255.0) as u8; 4]
    }));
    s.materials[0].albedo_texture = Some(1);
    s.materials[0].normal_texture = Some(2);
    s.materials[0].bump_scale = 0.05;
    s.settings.width = 48;
    s.settings.height = 48;
    s.settings.supersample = 3;
    let reference = trace(&s, 64, false);
    let (out, _): (FrameOutput, Scene) = render(&context(), s);
    let n = (reference.width * reference.height) as usize;
    let (mut far, mut sum_ref, mut sum_raster) = (0usize, 0.0f64, 0.0f64);
    for i in 0..n {
        for c in 0..3 {
            let pt = reference.mean[i * 3 + c] as f64;
            let sigma = (reference.variance[i * 3 + c] as f64).sqrt();
            let ras = out.radiance[i * 4 + c] as f64;
            sum_ref += pt;
            sum_raster += ras;
            if (pt - ras).abs() > 4.0 * sigma + 0.03 * pt.max(ras) + 1e-3 {
                far += 1;
            }
        }
    }
    let rel = (sum_raster - sum_ref).abs() / sum_ref;
    println!("image mean: rasterized {sum_raster:.3}, path traced {sum_ref:.3} ({:.2}%); {far} of {} values differ beyond noise", rel * 100.0, n * 3);
    assert!(rel < 0.01, "mean direct radiance differs by {:.2}%", rel * 100.0);
    // Shadow edges (PCF against exact visibility) and the mask's edge may differ.
    assert!(far * 100 < n * 3 * 3, "{far} of {} values differ beyond noise", n * 3);
}

//! Voxelization on the real device (lavapipe in CI, validation on) against CPU references.

mod common;

use common::*;
use dvsgi::render::Renderer;
use dvsgi::scene::*;
use glam::{Mat4, Vec3};
use std::collections::BTreeSet;
use std::path::PathBuf;

const RES: u32 = 32;

/// A scene whose voxel grid is exactly [0, RES]^3 in world units (voxel (i,j,k) = [i,i+1]x...).
fn scene(objects: Vec<(Mesh, bool, Motion)>) -> Scene {
    let mut s = Scene {
        sky: None,
        path: PathBuf::from("voxel-test"),
        name: "voxel test".into(),
        meshes: vec![],
        objects: vec![],
        materials: vec![
            Material::diffuse("a", Vec3::new(0.8, 0.4, 0.2)),
            Material::diffuse("b", Vec3::new(0.2, 0.6, 1.0)),
        ],
        textures: vec![],
        camera: Camera {
            position: Vec3::new(16.0, 16.0, -40.0),
            target: Vec3::splat(16.0),
            up: Vec3::Y,
            fov_y_deg: 45.0,
            near: 0.1,
            far: 200.0,
        },
        lights: vec![],
        settings: RenderSettings {
            width: 16,
            height: 16,
            gi: GiSettings { mode: GiMode::Vct, voxel_resolution: RES, ..Default::default() },
            ..Default::default()
        },
        bounds: Some(Aabb { min: Vec3::ZERO, max: Vec3::splat(RES as f32) }),
    };
    for (i, (m, dynamic, motion)) in objects.into_iter().enumerate() {
        s.meshes.push(m);
        s.objects.push(Object {
            name: format!("o{i}"),
            meshes: vec![i as u32],
            transform: Mat4::IDENTITY,
            dynamic,
            motion,
        });
    }
    s
}

/// Separating-axis overlap of a triangle and the box [c - h, c + h], by projecting onto all
/// 13 candidate axes.
fn overlaps(t: &[Vec3; 3], c: Vec3, h: f32) -> bool {
    let e = [t[1] - t[0], t[2] - t[1], t[0] - t[2]];
    let mut axes = vec![Vec3::X, Vec3::Y, Vec3::Z, e[0].cross(e[1])];
    for ei in e {
        for a in [Vec3::X, Vec3::Y, Vec3::Z] {
            axes.push(ei.cross(a));
        }
    }
    axes.into_iter().filter(|a| a.length_squared() > 1e-12).all(|a| {
        let p: Vec<f32> = t.iter().map(|v| a.dot(*v - c)).collect();
        let r = h * (a.x.abs() + a.y.abs() + a.z.abs());
        let (lo, hi) =
            (p.iter().cloned().fold(f32::INFINITY, f32::min), p.iter().cloned().fold(f32::NEG_INFINITY, f32::max));
        !(lo > r || hi < -r)
    })
}

type Voxel = (u32, u32, u32);

/// Voxels the triangle overlaps with every box shrunk (`grow` < 0) or grown by |grow|.
fn reference(t: &[Vec3; 3], grow: f32) -> BTreeSet<Voxel> {
    let mut out = BTreeSet::new();
    for k in 0..RES {
        for j in 0..RES {
            for i in 0..RES {
                let c = Vec3::new(i as f32, j as f32, k as f32) + 0.5;
                if overlaps(t, c, 0.5 + grow) {
                    out.insert((i, j, k));
                }
            }
        }
    }
    out
}

fn occupied(volume: &[u8], res: u32) -> BTreeSet<Voxel> {
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(volume);
    let mut out = BTreeSet::new();
    for (n, w) in words.iter().enumerate() {
        if w >> 24 != 0 {
            let n = n as u32;
            out.insert((n % res, (n / res) % res, n / (res * res)));
        }
    }
    out
}

fn albedo_volume(r: &mut Renderer) -> Vec<u8> {
    let v = r.voxels().expect("voxel volumes").albedo.clone();
    r.download_voxels(&v).unwrap()
}

/// Deterministic pseudo-random numbers in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn point(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * (hi - lo) + lo
    }
}

/// Thin, oblique, axis-aligned, tiny, boundary and random triangles: every voxel the triangle
/// touches (CPU separating-axis test, boxes shrunk by 1e-3) is set, and nothing farther than
/// 1e-3 from the triangle.
#[test]
fn voxelization_is_conservative_and_tight() {
    let v = Vec3::new;
    let mut tris: Vec<(&str, [Vec3; 3])> = vec![
        ("oblique", [v(3.2, 4.1, 5.3), v(20.7, 8.2, 25.1), v(10.3, 27.9, 12.6)]),
        ("thin oblique sliver", [v(2.3, 20.1, 3.7), v(28.6, 22.4, 27.2), v(2.33, 20.06, 3.72)]),
        ("axis-aligned (y = 5.3)", [v(4.2, 5.3, 4.7), v(14.8, 5.3, 6.1), v(9.1, 5.3, 15.6)]),
        ("axis-aligned sliver (z = 27.4)", [v(1.5, 10.2, 27.4), v(30.1, 10.25, 27.4), v(30.1, 10.21, 27.4)]),
        ("edge-on sliver along x", [v(1.2, 3.5, 3.5), v(30.7, 3.5, 3.5), v(30.7, 3.51, 3.52)]),
        ("tiny inside one voxel", [v(7.2, 7.3, 7.4), v(7.4, 7.3, 7.2), v(7.3, 7.6, 7.3)]),
        ("on a voxel boundary (x = 16)", [v(16.0, 2.5, 2.5), v(16.0, 12.5, 4.5), v(16.0, 6.5, 14.5)]),
        ("diagonal 45 degrees", [v(2.0, 2.0, 2.0), v(20.0, 20.0, 2.5), v(2.5, 2.0, 20.0)]),
    ];
    let mut rng = Lcg(7);
    let names: Vec<String> = (0..10).map(|i| format!("random {i}")).collect();
    for (i, name) in names.iter().enumerate() {
        let a = rng.point(0.5, 31.5);
        let span = if i % 2 == 0 { 12.0 } else { 3.0 };
        let b = (a + rng.point(-span, span)).clamp(Vec3::splat(0.5), Vec3::splat(31.5));
        let c = (a + rng.point(-span, span)).clamp(Vec3::splat(0.5), Vec3::splat(31.5));
        tris.push((name, [a, b, c]));
    }
    let ctx = context();
    for (name, t) in &tris {
        let mut r = Renderer::new(&ctx, scene(vec![(mesh(name, &[*t], 0, None), false, Motion::None)])).unwrap();
        r.render(0.0, false).unwrap();
        let got = occupied(&albedo_volume(&mut r), RES);
        let required = reference(t, -1e-3);
        let allowed = reference(t, 1e-3);
        let missing: Vec<_> = required.difference(&got).collect();
        let extra: Vec<_> = got.difference(&allowed).collect();
        assert!(
            missing.is_empty(),
            "{name}: {} of {} voxels missing, e.g. {:?}",
            missing.len(),
            required.len(),
            &missing[..missing.len().min(5)]
        );
        assert!(
            extra.is_empty(),
            "{name}: {} voxels set that the triangle does not touch, e.g. {:?}",
            extra.len(),
            &extra[..extra.len().min(5)]
        );
        assert!(!got.is_empty(), "{name}: nothing voxelized");
        // The work list holds the same voxels, within the capacity the triangle's bounds give.
        let list = r.voxel_list().unwrap().unwrap();
        check_work_list(&list, &got, &[1; (RES * RES * RES) as usize]);
        let capacity = r.voxels().unwrap().list.capacity;
        assert!(capacity >= got.len() as u64 && capacity < u64::from(RES).pow(3), "{name}: capacity {capacity}");
    }
    assert_no_validation_messages(&ctx);
}

/// The running average of two materials' albedos meeting in the same voxels is their mean,
/// and voxel normals point the surface's way.
#[test]
fn voxel_albedo_and_normal_are_averaged() {
    let v = Vec3::new;
    // Two coincident quads (as triangles) at y = 10.5 with different materials.
    let quad = [
        [v(4.0, 10.5, 4.0), v(12.0, 10.5, 4.0), v(12.0, 10.5, 12.0)],
        [v(4.0, 10.5, 4.0), v(12.0, 10.5, 12.0), v(4.0, 10.5, 12.0)],
    ];
    let ctx = context();
    let s =
        scene(vec![(mesh("a", &quad, 0, None), false, Motion::None), (mesh("b", &quad, 1, None), false, Motion::None)]);
    let mut r = Renderer::new(&ctx, s).unwrap();
    r.render(0.0, false).unwrap();
    let albedo: Vec<u32> = bytemuck::pod_collect_to_vec(&albedo_volume(&mut r));
    let normal_img = r.voxels().unwrap().normal.clone();
    let normal: Vec<u32> = bytemuck::pod_collect_to_vec(&r.download_voxels(&normal_img).unwrap());
    let idx = |i: u32, j: u32, k: u32| (i + RES * (j + RES * k)) as usize;
    let w = albedo[idx(8, 10, 8)];
    let rgb = [(w & 255) as f32 / 255.0, ((w >> 8) & 255) as f32 / 255.0, ((w >> 16) & 255) as f32 / 255.0];
    let expected = [0.5, 0.5, 0.6]; // mean of (0.8, 0.4, 0.2) and (0.2, 0.6, 1.0)
    for c in 0..3 {
        assert!((rgb[c] - expected[c]).abs() < 3.0 / 255.0, "albedo {rgb:?} vs {expected:?}");
    }
    assert!(w >> 24 >= 2, "two samples averaged, count {}", w >> 24);
    let n = normal[idx(8, 10, 8)];
    let ny = ((n >> 8) & 255) as f32 / 255.0 * 2.0 - 1.0;
    assert!(ny.abs() > 0.98, "normal y {ny}");
    assert_eq!(albedo[idx(8, 12, 8)], 0, "voxel above the quad is empty");
    assert_no_validation_messages(&ctx);
}

/// Known samples: 37 copies of one triangle, each with its own albedo and emission (drawn by
/// a fixed generator), meet in the same voxels, so each voxel receives exactly one sample of
/// each. Every stored channel is the exact mean of the 37 samples rounded to 8 bits: within half
/// an 8-bit step, plus the fixed point of the sums (1/65535 here: a tiny scene), and the count
/// is 37. (The running averages this replaced rounded at every step: up to several steps off.)
#[test]
fn voxel_averages_are_the_exact_mean_of_their_samples() {
    let v = Vec3::new;
    let tri = [v(4.3, 10.5, 4.2), v(27.7, 10.5, 5.1), v(9.2, 10.5, 26.6)];
    let mut rng = Lcg(11);
    let k: u32 = 37;
    let mut s = scene(vec![]);
    s.materials.clear();
    for i in 0..k {
        let mut m = Material::diffuse(&format!("m{i}"), v(rng.next(), rng.next(), rng.next()));
        m.emission = v(rng.next(), rng.next(), rng.next()) * 4.0;
        s.materials.push(m);
        s.meshes.push(mesh(&format!("t{i}"), &[tri], i, None));
        s.objects.push(Object {
            name: format!("o{i}"),
            meshes: vec![i],
            transform: Mat4::IDENTITY,
            dynamic: false,
            motion: Motion::None,
        });
    }
    let scale = s.materials.iter().map(|m| m.emission.max_element()).fold(0.0f32, f32::max);
    let mean = |f: &dyn Fn(&Material) -> Vec3| s.materials.iter().map(f).sum::<Vec3>() / k as f32;
    let (albedo_mean, emission_mean) = (mean(&|m| m.albedo), mean(&|m| m.emission / scale));
    let ctx = context();
    let mut r = Renderer::new(&ctx, s.clone()).unwrap();
    assert_eq!(r.voxels().unwrap().sum_scale, 65535);
    r.render(0.0, false).unwrap();
    let words = |r: &mut Renderer, img: std::sync::Arc<dvsgi::gpu::Image>| -> Vec<u32> {
        bytemuck::pod_collect_to_vec(&r.download_voxels(&img).unwrap())
    };
    let vols = r.voxels().unwrap();
    let images = (vols.albedo.clone(), vols.emission.clone().expect("emission"), vols.normal.clone());
    let (albedo, emission, normal) = (words(&mut r, images.0), words(&mut r, images.1), words(&mut r, images.2));
    let occupied: Vec<usize> = (0..albedo.len()).filter(|&i| albedo[i] != 0).collect();
    assert!(occupied.len() > 100, "{} voxels", occupied.len());
    let bound = 0.5 + 0.5 * 255.0 / 65535.0 + 1e-3;
    let mut worst = 0.0f32;
    for &i in &occupied {
        for (word, exact, what) in [(albedo[i], albedo_mean, "albedo"), (emission[i], emission_mean, "emission")] {
            assert_eq!(word >> 24, k, "{what} of voxel {i}: one sample per triangle");
            for c in 0..3 {
                let stored = ((word >> (8 * c)) & 255) as f32;
                let err = (stored - exact[c] * 255.0).abs();
                worst = worst.max(err);
                assert!(err <= bound, "{what} channel {c} of voxel {i}: {stored} against {}", exact[c] * 255.0);
            }
        }
        // The triangle's face normal (its winding): -y; in the fourth byte where the surface
        // lies along it from the voxel's centre (voxel.glsl, SUM_OFFSET): the plane y = 10.5
        // runs through the centres of the voxels it touches, offset 0, code 128 of 0..255.
        assert_eq!(normal[i] & 0xffffff, 128 | (128 << 16), "normal -y of voxel {i}");
        assert_eq!(normal[i] >> 24, 128, "the surface's offset in voxel {i}");
    }
    eprintln!("{} voxels, worst error {worst:.4} of an 8-bit step", occupied.len());
    assert_no_validation_messages(&ctx);
}

/// The same triangles in two orders (and, for good measure, the objects reversed) give the
/// same volumes, work list and image byte for byte: the sums commute, the static list is built
/// in grid order and brick slots are handed out in grid order. Dense and bricked, with a
/// dynamic object revoxelized twice, emission, and interleaved bounces (whose turns follow
/// list positions).
// Long: one scene built in two orders and two layouts; each comparison reads a different volume.
#[test]
fn triangle_order_does_not_change_the_voxels_or_the_image() {
    let reordered = |s: &Scene| {
        let mut s = s.clone();
        for m in &mut s.meshes {
            let tris: Vec<[u32; 3]> = m.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
            // Reversed (each triangle's vertices in their order: rotating them would change how
            // the G-buffer's rasterizer interpolates, in the last bits).
            m.indices = tris.iter().rev().flatten().copied().collect();
        }
        s.objects.reverse();
        s
    };
    let ctx = context();
    for layout in ["\"dense\"", "\"bricks\""] {
        let s = common::load(
            &repo().join("scenes/dynamic-test.toml"),
            &[
                ("render.width", "32"),
                ("render.height", "32"),
                ("gi.voxel_resolution", "32"),
                ("gi.bounces", "2"),
                ("gi.voxel_layout", layout),
            ],
        );
        let snapshot = |s: Scene| {
            let mut r = Renderer::new(&ctx, s).unwrap();
            for t in [0.0, 0.7, 1.9] {
                r.request_voxel_update();
                r.render(t, true).unwrap();
            }
            let v = r.voxels().unwrap();
            let images: Vec<_> = [&v.albedo, &v.normal, &v.radiance, v.final_radiance()]
                .into_iter()
                .chain(v.emission.iter())
                .cloned()
                .collect();
            let volumes: Vec<_> = images.iter().map(|i| (i.name.clone(), r.download_voxels(i).unwrap())).collect();
            // The dynamic voxels are appended as fragments arrive (their order decides nothing):
            // compared as sets.
            let mut list = r.voxel_list().unwrap().unwrap();
            list.entries[list.static_count as usize..].sort_unstable();
            list.stale.sort_unstable();
            let bricks = r.resident_bricks().unwrap();
            (volumes, list, format!("{bricks:?}"), r.output().radiance)
        };
        let (a, b) = (snapshot(s.clone()), snapshot(reordered(&s)));
        for ((name, x), (_, y)) in a.0.iter().zip(&b.0) {
            let differing = x.iter().zip(y).filter(|(p, q)| p != q).count();
            assert_eq!(differing, 0, "{layout}: {name}: {differing} bytes differ between the two orders");
        }
        assert!(a.1.static_count > 0 && a.1.entries.len() > a.1.static_count as usize, "{:?}", a.1.static_count);
        assert_eq!(a.1, b.1, "{layout}: the work list");
        assert_eq!(a.2, b.2, "{layout}: the resident bricks and their slots");
        assert!(a.3.iter().any(|v| *v > 0.0));
        assert!(a.3 == b.3, "{layout}: the images differ");
    }
    assert_no_validation_messages(&ctx);
}

/// A dynamic object moves: its old voxels are gone, its new ones present, and every static
/// voxel (flag set) keeps its exact value. The work list follows: it holds exactly the
/// occupied voxels after each update, and the voxels the object left become its stale list,
/// zeroed in every radiance volume.
// Long: one scene rendered before and after its object moves; each check reads the state both frames left.
#[test]
fn dynamic_update_clears_old_voxels_and_keeps_static_ones() {
    let v = Vec3::new;
    let floor = [
        [v(1.0, 2.5, 1.0), v(31.0, 2.5, 1.0), v(31.0, 2.5, 31.0)],
        [v(1.0, 2.5, 1.0), v(31.0, 2.5, 31.0), v(1.0, 2.5, 31.0)],
    ];
    let wall = [[v(1.0, 1.0, 25.5), v(31.0, 1.0, 25.5), v(31.0, 20.0, 25.5)]];
    let blob = [
        [v(5.2, 8.3, 5.1), v(9.7, 8.6, 5.4), v(7.1, 13.2, 9.6)],
        [v(5.2, 8.3, 5.1), v(7.1, 13.2, 9.6), v(4.9, 12.1, 8.8)],
    ];
    let motion = Motion::Keyframes(vec![
        Keyframe { time: 0.0, translate: Vec3::ZERO, rotate_deg: Vec3::ZERO, scale: Vec3::ONE },
        Keyframe { time: 1.0, translate: v(14.0, 0.0, 6.0), rotate_deg: Vec3::ZERO, scale: Vec3::ONE },
    ]);
    let ctx = context();
    let mut s = scene(vec![
        (mesh("floor", &floor, 0, None), false, Motion::None),
        (mesh("wall", &wall, 0, None), false, Motion::None),
        (mesh("blob", &blob, 1, None), true, motion.clone()),
    ]);
    // An emissive blob: its voxels carry radiance wherever it is (and lose it when it leaves).
    s.materials[1].emission = Vec3::new(2.0, 1.0, 0.5);
    s.settings.gi.voxel_layout = VoxelLayout::Bricks;
    let mut r = Renderer::new(&ctx, s).unwrap();
    assert!(r.pass_names(false).contains(&"voxel clear dynamic".to_string()));
    let flags_img = r.voxels().unwrap().flags.clone().expect("a flag volume for a dynamic scene");
    r.render(0.0, false).unwrap();
    let a0 = albedo_volume(&mut r);
    let flags: Vec<u8> = r.download_voxels(&flags_img).unwrap();
    let l0 = r.voxel_list().unwrap().unwrap();
    let bricks0 = r.resident_bricks().unwrap().expect("bricked");
    r.render(1.0, false).unwrap();
    let a1 = albedo_volume(&mut r);
    let l1 = r.voxel_list().unwrap().unwrap();
    let bricks1 = r.resident_bricks().unwrap().expect("bricked");
    assert!(!r.pass_names(false).contains(&"voxelize static".to_string()), "static geometry is voxelized once");
    check_work_list(&l0, &occupied(&a0, RES), &flags);
    check_work_list(&l1, &occupied(&a1, RES), &flags);
    // The second update's clear emptied exactly the first update's dynamic voxels.
    let dynamic0: BTreeSet<Voxel> = l0.entries[l0.static_count as usize..].iter().map(|c| (c[0], c[1], c[2])).collect();
    let stale1: BTreeSet<Voxel> = l1.stale.iter().map(|c| (c[0], c[1], c[2])).collect();
    assert_eq!((stale1.len(), &stale1), (l1.stale.len(), &dynamic0), "the stale list is the old dynamic range");
    assert_eq!(l1.stale_groups, groups(l1.stale.len()));
    // Every radiance volume is occupied (alpha 1) exactly where the voxels are now: the
    // voxels the blob left were zeroed, not left with their old light.
    let occ1 = occupied(&a1, RES);
    let v = r.voxels().unwrap();
    let volumes = [v.radiance.clone(), v.final_radiance().clone()];
    for img in volumes {
        let lit: BTreeSet<Voxel> = f16_volume(&mut r, &img)
            .iter()
            .enumerate()
            .filter(|(_, p)| p[3] != 0.0 || p[..3] != [0.0; 3])
            .map(|(n, _)| (n as u32 % RES, (n as u32 / RES) % RES, n as u32 / (RES * RES)))
            .collect();
        assert_eq!(lit, occ1, "{}: non-zero exactly at the occupied voxels", img.name);
    }

    let blob_at = |t: f32| -> BTreeSet<Voxel> {
        let m = motion.matrix(t);
        blob.iter().flat_map(|tri| reference(&tri.map(|p| m.transform_point3(p)), -1e-3)).collect()
    };
    let static_set: BTreeSet<Voxel> = floor.iter().chain(wall.iter()).flat_map(|t| reference(t, -1e-3)).collect();
    let static_allowed: BTreeSet<Voxel> = floor.iter().chain(wall.iter()).flat_map(|t| reference(t, 1e-3)).collect();
    let (occ0, occ1) = (occupied(&a0, RES), occupied(&a1, RES));
    let (b0, b1) = (blob_at(0.0), blob_at(1.0));
    assert!(b0.is_subset(&occ0) && b1.is_subset(&occ1), "dynamic voxels present at both times");
    for vox in b0.difference(&b1).filter(|v| !static_allowed.contains(v)) {
        assert!(!occ1.contains(vox), "old dynamic voxel {vox:?} survived the move");
    }
    let idx = |(i, j, k): Voxel| (i + RES * (j + RES * k)) as usize;
    let w0: Vec<u32> = bytemuck::pod_collect_to_vec(&a0);
    let w1: Vec<u32> = bytemuck::pod_collect_to_vec(&a1);
    let mut checked = 0;
    for vox in &static_set {
        if b0.contains(vox) || b1.contains(vox) {
            continue;
        }
        assert_eq!(flags[idx(*vox)], 1, "static voxel {vox:?} is flagged");
        assert_eq!(w0[idx(*vox)], w1[idx(*vox)], "static voxel {vox:?} changed");
        checked += 1;
    }
    assert!(checked > 500, "checked {checked} static voxels");
    // Resident bricks: the bricks of the occupied voxels and those whose aprons hold one (a
    // voxel that is the last of its brick on an axis is also in the apron of the brick above),
    // before and after the move (the bricks the blob left are released, those it reached made
    // resident). Within the CPU model's bricks, and none dropped.
    let bricks_of = |set: &BTreeSet<Voxel>| -> BTreeSet<Voxel> {
        let span = |c: u32| c / 8..=(c + 1) / 8;
        set.iter()
            .flat_map(|&(i, j, k)| {
                span(k).flat_map(move |z| span(j).flat_map(move |y| span(i).map(move |x| (x, y, z))))
            })
            .collect()
    };
    let resident = |b: &dvsgi::render::voxel::bricks::BrickSnapshot| -> BTreeSet<Voxel> {
        assert_eq!((b.pools.len(), b.pools[0].dropped), (1, 0), "one pool at {RES}^3, nothing dropped");
        b.pools[0].resident.iter().map(|c| (c[0], c[1], c[2])).collect()
    };
    assert_eq!(resident(&bricks0), bricks_of(&occ0), "resident bricks after the first voxelization");
    assert_eq!(resident(&bricks1), bricks_of(&occ1), "resident bricks after the move");
    let cpu_least = bricks_of(&static_set.iter().chain(&b1).cloned().collect());
    assert!(cpu_least.is_subset(&resident(&bricks1)), "every brick the CPU model occupies is resident");
    let left = bricks_of(&occ0).difference(&bricks_of(&occ1)).count();
    let reached = bricks_of(&occ1).difference(&bricks_of(&occ0)).count();
    assert!(left > 0 && reached > 0, "the blob left {left} bricks and reached {reached}: the test says little");
    // Nothing but static and dynamic geometry is set.
    let everything: BTreeSet<Voxel> = static_allowed
        .union(&blob.iter().flat_map(|t| reference(&t.map(|p| motion.matrix(1.0).transform_point3(p)), 1e-3)).collect())
        .cloned()
        .collect();
    assert!(occ1.is_subset(&everything));
    assert_no_validation_messages(&ctx);
}

/// Indirect dispatch arguments over `n` list entries (64 per group, glsl/include/voxel_list.glsl).
fn groups(n: usize) -> [u32; 3] {
    let g = n.div_ceil(64) as u32;
    [g.min(32768), g.div_ceil(32768), 1]
}

/// The work list holds every occupied voxel of the albedo volume once (a CPU reference from
/// the volume read back), static voxels (flag set) first, and the dispatch arguments cover it.
fn check_work_list(list: &dvsgi::render::voxel::ListSnapshot, occupied: &BTreeSet<Voxel>, flags: &[u8]) {
    let entries: Vec<Voxel> = list.entries.iter().map(|c| (c[0], c[1], c[2])).collect();
    let set: BTreeSet<Voxel> = entries.iter().copied().collect();
    assert_eq!(set.len(), entries.len(), "no voxel is listed twice");
    assert_eq!(&set, occupied, "the list holds exactly the occupied voxels");
    assert_eq!(list.dropped, 0);
    let flagged = |(i, j, k): Voxel| flags.get((i + RES * (j + RES * k)) as usize).is_some_and(|f| *f != 0);
    let s = list.static_count as usize;
    assert!(entries[..s].iter().all(|v| flagged(*v)), "static entries first");
    assert!(entries[s..].iter().all(|v| !flagged(*v)), "then the dynamic ones");
    assert_eq!(list.occupied_groups, groups(entries.len()));
    assert_eq!(list.dynamic_groups, groups(entries.len() - s));
}

/// RGBA16F voxel radiance volume as f32 RGBA, rgb in radiance units (the volume holds radiance
/// times the scene's radiance scale; alpha is occupancy).
fn radiance_volume(r: &mut Renderer) -> Vec<[f32; 4]> {
    let img = r.voxels().unwrap().radiance.clone();
    let k = 1.0 / r.voxels().unwrap().radiance_scale;
    let halves: Vec<half::f16> = bytemuck::pod_collect_to_vec(&r.download_voxels(&img).unwrap());
    halves.chunks_exact(4).map(|c| [c[0].to_f32() * k, c[1].to_f32() * k, c[2].to_f32() * k, c[3].to_f32()]).collect()
}

fn cornell_vct(overrides: &[(&str, &str)]) -> Scene {
    let mut all =
        vec![("render.width", "16"), ("render.height", "16"), ("gi.mode", "\"vct\""), ("gi.voxel_resolution", "64")];
    all.extend_from_slice(overrides);
    common::load(&repo().join("scenes/cornell-box.toml"), &all)
}

/// The floor voxel under the point light carries albedo/pi * I cos / d^2 (evaluated at the
/// voxel centre with the volume's own 8-bit albedo) within 1%, for both attenuation modes and
/// both occlusion methods; floor voxels deep in a block's shadow are dark with both methods;
/// every value is finite.
// Long: a table of attenuation x occlusion cases, each checked against the same analytic sums.
#[test]
fn voxel_lighting_matches_analytic_irradiance_and_shadows() {
    let ctx = context();
    for (attenuation, occlusion) in
        [("normal-weighted", "shadow-map"), ("n-dot-l", "shadow-map"), ("normal-weighted", "raymarch")]
    {
        let scene = cornell_vct(&[
            ("gi.attenuation", &format!("{attenuation:?}")),
            ("gi.occlusion", &format!("{occlusion:?}")),
        ]);
        let (light, intensity) = match scene.lights[0].kind {
            LightKind::Point { position, intensity } => (position, intensity),
            _ => unreachable!(),
        };
        let tris = triangles(&scene, 0.0);
        let mut r = Renderer::new(&ctx, scene).unwrap();
        r.render(0.0, false).unwrap();
        let grid = r.voxels().unwrap().grid;
        let res = grid.resolution;
        let rad = radiance_volume(&mut r);
        let alb: Vec<u32> = bytemuck::pod_collect_to_vec(&albedo_volume(&mut r));
        assert!(rad.iter().flatten().all(|v| v.is_finite()), "non-finite voxel radiance");
        let idx = |c: glam::UVec3| (c.x + res * (c.y + res * c.z)) as usize;
        let cell = |p: Vec3| ((p - grid.origin) / grid.voxel_size).floor().as_uvec3();
        let centre = |c: glam::UVec3| grid.origin + (c.as_vec3() + 0.5) * grid.voxel_size;
        let what = format!("{attenuation}/{occlusion}");

        // Lit: every floor voxel within 10 cm of the point under the light whose average normal
        // is the floor's alone (a voxel the tall block's face also touches averages both), unblocked.
        let nimg = r.voxels().unwrap().normal.clone();
        let nrm: Vec<u32> = bytemuck::pod_collect_to_vec(&r.download_voxels(&nimg).unwrap());
        let floor_y = cell(Vec3::new(0.0, 1e-4, 0.0)).y;
        let mut lit = 0;
        let mut peak = 0.0f32;
        for z in 0..res {
            for x in 0..res {
                let c = glam::UVec3::new(x, floor_y, z);
                let p = centre(c);
                let (w, n) = (alb[idx(c)], nrm[idx(c)]);
                let ny = ((n >> 8) & 255) as f32 / 255.0 * 2.0 - 1.0;
                if w >> 24 == 0 || ny < 0.99 || Vec3::new(p.x - light.x, 0.0, p.z - light.z).length() > 0.1 {
                    continue;
                }
                // Rays from a tube two voxels wide around the voxel must reach the light: at a
                // shadow edge filtered visibility is legitimately partial, and voxelized (hence
                // up to a voxel fatter) occluders cast slightly larger ray-marched shadows.
                let unblocked = |dx: f32, dy: f32, dz: f32| {
                    let q = p + Vec3::new(dx, dy, dz) * grid.voxel_size;
                    raycast(&tris, q, (light - q).normalize(), 1e-4, (light - q).length()).is_none()
                };
                let tube = [-2.0, 0.0, 2.0];
                if !tube.iter().all(|&dx| tube.iter().all(|&dz| [1.0, 2.5].iter().all(|&dy| unblocked(dx, dy, dz)))) {
                    continue;
                }
                let albedo = Vec3::new((w & 255) as f32, ((w >> 8) & 255) as f32, ((w >> 16) & 255) as f32) / 255.0;
                let l = light - p;
                let expected = albedo / std::f32::consts::PI * intensity * (l.y / l.length()) / l.length_squared();
                let got = Vec3::from_slice(&rad[idx(c)][..3]);
                for ch in 0..3 {
                    let rel = (got[ch] - expected[ch]).abs() / expected[ch];
                    assert!(
                        rel < 0.01,
                        "{what}: voxel {c} channel {ch}: {} vs analytic {} ({:.2}% off)",
                        got[ch],
                        expected[ch],
                        rel * 100.0
                    );
                }
                assert_eq!(rad[idx(c)][3], 1.0, "occupied voxels are opaque");
                peak = peak.max(expected.max_element());
                lit += 1;
            }
        }
        assert!(lit > 50, "{what}: only {lit} lit floor voxels checked");
        let expected = Vec3::splat(peak);

        // Shadowed: floor voxels whose centre and 3x3 neighbourhood (in x, z) are blocked.
        let blocked = |c: glam::UVec3| {
            let q = centre(c) + Vec3::Y * grid.voxel_size;
            let l = light - q;
            raycast(&tris, q, l.normalize(), 1e-4, l.length()).is_some()
        };
        let mut dark = 0;
        for z in 2..res - 2 {
            for x in 2..res - 2 {
                let c = glam::UVec3::new(x, cell(Vec3::new(0.0, 1e-4, 0.0)).y, z);
                if alb[idx(c)] >> 24 == 0 {
                    continue;
                }
                let all_blocked = (0..9).all(|i| blocked(glam::UVec3::new(x + i % 3 - 1, c.y, z + i / 3 - 1)));
                if all_blocked
                    && (0..9).all(|i| alb[idx(glam::UVec3::new(x + i % 3 - 1, c.y, z + i / 3 - 1))] >> 24 > 0)
                {
                    let v = Vec3::from_slice(&rad[idx(c)][..3]);
                    assert!(
                        v.max_element() < 1e-3 * expected.max_element(),
                        "{what}: shadowed floor voxel {c} has {v}"
                    );
                    dark += 1;
                }
            }
        }
        assert!(dark > 20, "{what}: only {dark} shadowed floor voxels checked");
    }
    assert_no_validation_messages(&ctx);
}

/// No lights and no emission: every voxel is black. An emissive quad and no lights: its
/// voxels carry its emitted radiance (within the 8-bit step of the emission scale).
#[test]
fn voxel_radiance_is_black_without_light_and_carries_emission() {
    let ctx = context();
    let v = Vec3::new;
    let quad = [
        [v(4.0, 10.5, 4.0), v(12.0, 10.5, 4.0), v(12.0, 10.5, 12.0)],
        [v(4.0, 10.5, 4.0), v(12.0, 10.5, 12.0), v(4.0, 10.5, 12.0)],
    ];
    let mut s = scene(vec![(mesh("quad", &quad, 0, None), false, Motion::None)]);
    let mut r = Renderer::new(&ctx, s.clone()).unwrap();
    r.render(0.0, false).unwrap();
    let rad = radiance_volume(&mut r);
    assert!(rad.iter().all(|p| p[..3] == [0.0; 3]), "black without lights and emission");
    assert!(rad.iter().filter(|p| p[3] == 1.0).count() > 50, "the quad's voxels are occupied");
    drop(r);

    let emission = Vec3::new(17.0, 12.0, 4.0);
    s.materials[0].emission = emission;
    let mut r = Renderer::new(&ctx, s).unwrap();
    r.render(0.0, false).unwrap();
    let rad = radiance_volume(&mut r);
    let got = rad[(8 + RES * (10 + RES * 8)) as usize];
    let step = 17.0 / 255.0;
    for ch in 0..3 {
        assert!((got[ch] - emission[ch]).abs() <= step, "emission channel {ch}: {} vs {}", got[ch], emission[ch]);
    }
    assert_no_validation_messages(&ctx);
}

/// A full-resolution RGBA16F volume as f32 RGBA, N^3 whatever the layout.
fn f16_volume(r: &mut Renderer, img: &std::sync::Arc<dvsgi::gpu::Image>) -> Vec<[f32; 4]> {
    f16_rgba(&r.download_voxels(img).unwrap())
}

/// Level `level` of directional volume `face` as f32 RGBA, whatever the layout.
fn f16_directional(r: &mut Renderer, face: usize, level: u32) -> Vec<[f32; 4]> {
    f16_rgba(&r.download_directional(face, level).unwrap())
}

fn f16_rgba(bytes: &[u8]) -> Vec<[f32; 4]> {
    let halves: Vec<half::f16> = bytemuck::pod_collect_to_vec(bytes);
    halves.chunks_exact(4).map(|c| [c[0].to_f32(), c[1].to_f32(), c[2].to_f32(), c[3].to_f32()]).collect()
}

/// Optical depth of an opaque voxel (voxel.glsl's VOXEL_TAU).
const VOXEL_TAU: f32 = 5.545177;

/// Premultiplied (c, alpha) -> (L * tau, tau), as voxel.glsl's `tau_from_alpha`.
fn tau_from_alpha(p: [f32; 4]) -> [f32; 4] {
    let a = p[3].clamp(0.0, 1.0);
    if a <= 0.0 {
        return [0.0; 4];
    }
    let tau = (-(1.0 - a).max(1e-30).ln()).min(VOXEL_TAU);
    [p[0].max(0.0) / a * tau, p[1].max(0.0) / a * tau, p[2].max(0.0) / a * tau, tau]
}

/// (L * tau, tau) -> premultiplied (c, alpha), as voxel.glsl's `alpha_from_tau`.
fn alpha_from_tau(t: [f32; 4]) -> [f32; 4] {
    let tau = t[3].max(0.0);
    if tau <= 0.0 {
        return [0.0; 4];
    }
    let a = 1.0 - (-tau).exp();
    [t[0].max(0.0) / tau * a, t[1].max(0.0) / tau * a, t[2].max(0.0) / tau * a, a]
}

/// CPU reference of one directional level: for face f (+x, -x, +y, -y, +z, -z) each texel
/// composites the front voxel of each of its four rows over the back one (premultiplied) and
/// averages the rows, then stores (L * tau, tau). `src` is the full-resolution volume (already
/// premultiplied) when `from_full`, else the level below in (L * tau, tau). The result is
/// rounded to half floats, as the GPU stores it.
fn directional_level(src: &[[f32; 4]], n: u32, face: usize, from_full: bool) -> Vec<[f32; 4]> {
    let m = n / 2;
    let axis = face / 2;
    let front_is_low = face % 2 == 0;
    let at = |p: [u32; 3]| {
        let v = src[((p[2] * n + p[1]) * n + p[0]) as usize];
        if from_full {
            v
        } else {
            alpha_from_tau(v)
        }
    };
    let mut out = Vec::with_capacity((m * m * m) as usize);
    for z in 0..m {
        for y in 0..m {
            for x in 0..m {
                let mut acc = [0f32; 4];
                for u in 0..2 {
                    for v in 0..2 {
                        let mut lo = [2 * x, 2 * y, 2 * z];
                        let others: Vec<usize> = (0..3).filter(|&a| a != axis).collect();
                        lo[others[0]] += u;
                        lo[others[1]] += v;
                        let mut hi = lo;
                        hi[axis] += 1;
                        let (f, b) = if front_is_low { (at(lo), at(hi)) } else { (at(hi), at(lo)) };
                        for c in 0..4 {
                            acc[c] += f[c] + (1.0 - f[3].clamp(0.0, 1.0)) * b[c];
                        }
                    }
                }
                out.push(tau_from_alpha(acc.map(|a| a * 0.25)).map(|a| half::f16::from_f32(a).to_f32()));
            }
        }
    }
    out
}

/// The six directional mip chains against the CPU reference, level by level, on a random
/// volume (random triangles, half of them emissive, one bounce so the chain is built from the
/// bounced volume), each voxel seen alike from every side (`gi.plane_backs = "lit"`, which the
/// reference integrates; the other rules are tested by their effect, tests/gi_truth.rs).
#[test]
fn anisotropic_mips_match_the_cpu_reference() {
    let ctx = context();
    let mut rng = Lcg(0x5eed);
    let objects = (0..24)
        .map(|i| {
            let c = rng.point(4.0, 28.0);
            let tri = [c + rng.point(-6.0, 6.0), c + rng.point(-6.0, 6.0), c + rng.point(-6.0, 6.0)];
            (mesh(&format!("t{i}"), &[tri], i % 2, None), false, Motion::None)
        })
        .collect();
    let mut s = scene(objects);
    s.materials[0].emission = Vec3::new(3.0, 1.5, 0.25);
    s.settings.gi.bounces = 1;
    s.settings.gi.plane_backs = dvsgi::scene::PlaneBacks::Lit;
    let mut r = Renderer::new(&ctx, s).unwrap();
    r.render(0.0, false).unwrap();
    let v = r.voxels().unwrap();
    let (source, dirs) = (v.final_radiance().clone(), v.directional.clone());
    let pooled = v.bricks.as_ref().map_or(0, |b| b.directional.len() as u32);
    assert_eq!(dirs.len(), 6);
    let full = f16_volume(&mut r, &source);
    assert!(full.iter().any(|t| t[3] > 0.0) && full.iter().any(|t| t[0] > 0.0), "the volume is not empty");
    let levels = dirs[0].desc.mip_levels + pooled;
    assert_eq!(levels, RES.trailing_zeros(), "half resolution down to one voxel");
    // The volume is anisotropic: opposite directions differ somewhere.
    let (px, nx) = (f16_directional(&mut r, 0, 0), f16_directional(&mut r, 1, 0));
    assert!(px.iter().zip(&nx).any(|(a, b)| (a[0] - b[0]).abs() > 0.05), "+x and -x are identical");
    for face in 0..dirs.len() {
        let mut below = full.clone();
        let mut n = RES;
        for level in 0..levels {
            let expected = directional_level(&below, n, face, level == 0);
            let got = f16_directional(&mut r, face, level);
            assert_eq!(got.len(), expected.len());
            for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
                for c in 0..4 {
                    assert!(
                        (g[c] - e[c]).abs() <= 2e-3 * e[c].abs().max(1.0),
                        "face {face} level {level} texel {i} channel {c}: GPU {} vs CPU {}",
                        g[c],
                        e[c]
                    );
                }
            }
            // The next level is built from what the GPU stored.
            below = got;
            n /= 2;
        }
    }
    drop(r);
    assert_no_validation_messages(&ctx);
}

/// Nothing inside the grid: voxelization lists no voxel, every list-driven dispatch has zero
/// groups, the volumes stay zero and the lit frame is black (the light shines on nothing).
#[test]
fn an_empty_grid_dispatches_nothing_and_stays_black() {
    let ctx = context();
    let v = Vec3::new;
    // A triangle far outside the grid [0, 32]^3 (and out of view).
    let outside = [[v(100.0, 100.0, 100.0), v(110.0, 100.0, 100.0), v(100.0, 110.0, 100.0)]];
    let mut s = scene(vec![(mesh("outside", &outside, 0, None), true, Motion::None)]);
    s.settings.gi.voxel_layout = VoxelLayout::Bricks;
    s.lights.push(Light {
        name: "bulb".into(),
        kind: LightKind::Point { position: Vec3::splat(16.0), intensity: Vec3::splat(50.0) },
        cast_shadows: true,
        motion: Motion::None,
    });
    let mut r = Renderer::new(&ctx, s).unwrap();
    for t in [0.0, 1.0] {
        r.request_voxel_update();
        r.render(t, true).unwrap();
        let list = r.voxel_list().unwrap().unwrap();
        assert!(list.entries.is_empty() && list.static_count == 0 && list.stale.is_empty());
        let bricks = r.resident_bricks().unwrap().expect("bricked");
        assert!(bricks.pools.iter().all(|p| p.resident.is_empty() && p.dropped == 0), "no brick is resident");
        for g in [list.occupied_groups, list.dynamic_groups, list.stale_groups] {
            assert_eq!(g[0] * g[1] * g[2], 0, "no workgroups dispatched: {g:?}");
        }
        let out = r.output();
        assert!(out.radiance.chunks_exact(4).all(|p| p[..3] == [0.0; 3]), "the frame is black");
        let vols = r.voxels().unwrap();
        let imgs = [vols.radiance.clone(), vols.final_radiance().clone()];
        for img in imgs {
            assert!(f16_volume(&mut r, &img).iter().all(|p| *p == [0.0; 4]), "{} is zero", img.name);
        }
    }
    assert_no_validation_messages(&ctx);
}

/// `gi.bounce_interleave = 4`: a feedback update gathers the bounce for exactly the static
/// voxels whose list workgroup (64 entries) is its phase modulo 4 (the others keep their
/// indirect light, bit for bit), and after the light moves the image converges on a fresh
/// render as without it.
#[test]
fn bounce_interleave_gathers_one_in_n_static_voxels_per_update_and_converges() {
    let ctx = context();
    let scene = |extra: &[(&str, &str)]| {
        let mut o = vec![("gi.voxel_resolution", "32"), ("lights.0.motion", "{ velocity = [0, -0.25, 0] }")];
        o.extend_from_slice(extra);
        cornell_vct(&o)
    };
    let mut r = Renderer::new(&ctx, scene(&[("gi.bounce_interleave", "4")])).unwrap();
    let scratch = r.voxels().unwrap().bounced[1].clone();
    r.render(0.0, false).unwrap();
    let before = f16_volume(&mut r, &scratch);
    // The second update (phase 1 of 4), after the light moved.
    r.render(1.0, false).unwrap();
    let after = f16_volume(&mut r, &scratch);
    let list = r.voxel_list().unwrap().unwrap();
    assert_eq!(list.static_count as usize, list.entries.len());
    let (mut gathered, mut changed) = (0, 0);
    for (i, c) in list.entries.iter().enumerate() {
        let n = (c[0] + RES * (c[1] + RES * c[2])) as usize;
        if (i / 64) % 4 == 1 {
            gathered += 1;
            changed += usize::from(before[n] != after[n]);
        } else {
            assert_eq!(before[n], after[n], "entry {i} (voxel {c:?}) is not in this update's quarter");
        }
    }
    assert!(changed * 10 >= gathered * 9, "only {changed} of {gathered} gathered voxels changed");
    drop(r);
    // The lag: after the light moves, each update's image against a fresh render at the new
    // position, without interleave and with 4 (the price of a quarter of the bounce's cost).
    let mean = |r: &mut Renderer, t: f32| {
        r.render(t, true).unwrap();
        r.output().radiance.chunks_exact(4).map(|p| f64::from(p[0] + p[1] + p[2])).sum::<f64>()
    };
    let mut fresh = Renderer::new(&ctx, scene(&[("gi.first_update_bounces", "8")])).unwrap();
    let target = mean(&mut fresh, 1.0);
    drop(fresh);
    let lag = |k: &str| -> Vec<f64> {
        let mut r = Renderer::new(&ctx, scene(&[("gi.bounce_interleave", k)])).unwrap();
        r.render(0.0, false).unwrap();
        (0..16).map(|_| (mean(&mut r, 1.0) / target - 1.0).abs()).collect()
    };
    let (one, four) = (lag("1"), lag("4"));
    eprintln!("error after the light moved, per update: interleave 1 {one:.4?}; interleave 4 {four:.4?}");
    assert!(one[3] < 0.02, "interleave 1, four updates after the move: {one:?}");
    assert!(four[15] < 0.02 && four[15] <= four[0], "interleave 4, sixteen updates after: {four:?}");
    assert_no_validation_messages(&ctx);
}

/// The bricked layout renders what the dense one does: the Cornell box at 64^3 (full-resolution
/// bricks) and 256^3 (the directional level 0 in bricks with aprons too), within FLIP 0.005
/// and 0.5% of the mean radiance (measured: FLIP 0.0004 and 0.0000, means equal to 1e-5).
#[test]
fn bricked_and_dense_layouts_render_the_same_image() {
    let ctx = context();
    for res in ["64", "256"] {
        let image = |layout: &str| {
            let s = common::load(
                &repo().join("scenes/cornell-box.toml"),
                &[
                    ("render.width", "48"),
                    ("render.height", "48"),
                    ("gi.voxel_resolution", res),
                    ("gi.voxel_layout", layout),
                ],
            );
            let (out, _) = render(&ctx, s);
            let rgb = out.radiance.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
            dvsgi::metrics::LinearImage { width: 48, height: 48, rgb }
        };
        assert_same_image(&format!("{res}^3"), &image("\"bricks\""), &image("\"dense\""));
    }
    assert_no_validation_messages(&ctx);
}

/// Two moving cubes, with the directional level 0 in bricks too (256^3): after they have moved
/// twice (each update releases the dynamic bricks, allocates them anew and empties their
/// slots), the bricked layout renders what the dense one does, to the same bounds as above.
#[test]
fn bricked_and_dense_layouts_agree_after_dynamic_objects_move() {
    let ctx = context();
    let image = |layout: &str| {
        let s = common::load(
            &repo().join("scenes/dynamic-test.toml"),
            &[
                ("render.width", "48"),
                ("render.height", "48"),
                ("gi.voxel_resolution", "256"),
                ("gi.voxel_layout", layout),
                ("gi.bounce_feedback", "false"),
            ],
        );
        let mut r = Renderer::new(&ctx, s).unwrap();
        for t in [0.0, 1.0, 2.5] {
            r.request_voxel_update();
            r.render(t, true).unwrap();
        }
        let resident =
            r.resident_bricks().unwrap().map(|b| b.pools.iter().map(|p| p.resident.len()).collect::<Vec<_>>());
        let rgb = r.output().radiance.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        (dvsgi::metrics::LinearImage { width: 48, height: 48, rgb }, resident)
    };
    let ((bricks, resident), (dense, _)) = (image("\"bricks\""), image("\"dense\""));
    let resident = resident.expect("bricks");
    assert_eq!(resident.len(), 2, "the full-resolution pool and the directional level 0: {resident:?}");
    assert_same_image(&format!("after the moves (resident bricks {resident:?})"), &bricks, &dense);
    assert_no_validation_messages(&ctx);
}

/// Pool 0's radiance volumes store each brick with an apron (its low neighbours' last texels),
/// written by every radiance writer (`RADIANCE_STORE`): after moving objects have been
/// revoxelized, relit and bounced, every apron texel of every resident brick holds exactly
/// what the voxel it copies holds (zero where that voxel's brick is not resident or is outside
/// the grid), in the direct and the bounced radiance.
#[test]
fn every_radiance_apron_holds_the_texels_of_the_bricks_below() {
    let ctx = context();
    let s = common::load(
        &repo().join("scenes/dynamic-test.toml"),
        &[
            ("render.width", "16"),
            ("render.height", "16"),
            ("gi.voxel_resolution", "64"),
            ("gi.voxel_layout", "\"bricks\""),
        ],
    );
    let mut r = Renderer::new(&ctx, s).unwrap();
    for t in [0.0, 1.0, 2.5] {
        r.request_voxel_update();
        r.render(t, false).unwrap();
    }
    let v = r.voxels().expect("voxels");
    let (n, bricks) = (v.grid.resolution as i64, v.bricks.as_ref().expect("bricks"));
    let (pool, map_image) = (bricks.layout.pools[0], bricks.maps[0].clone());
    let volumes = [v.radiance.clone(), v.bounced[0].clone()];
    let map: Vec<u32> = bytemuck::pod_collect_to_vec(&r.download(&map_image).unwrap());
    let m = pool.map_side as i64;
    assert_eq!((m, pool.stride), (n / 8 + 1, 9));
    for img in volumes {
        let dense = f16_volume(&mut r, &img);
        let pooled = f16_rgba(&r.download(&img).unwrap());
        let ext = pool.extent().map(|e| e as i64);
        let (mut checked, mut nonzero) = (0, 0);
        for (i, &entry) in map.iter().enumerate().filter(|(_, &e)| e != 0) {
            let b = [i as i64 % m, (i as i64 / m) % m, i as i64 / (m * m)];
            let slot =
                dvsgi::render::voxel::bricks::Pool::entry_slot(entry).expect("a resident brick's entry").map(i64::from);
            assert!((0..3).all(|k| slot[k] < pool.slots[k] as i64), "brick {b:?}: slot {slot:?} outside the pool");
            for (z, y, x) in (0..9).flat_map(|z| (0..9).flat_map(move |y| (0..9).map(move |x| (z, y, x)))) {
                if x != 0 && y != 0 && z != 0 {
                    continue; // the interior
                }
                let c = [b[0] * 8 - 1 + x, b[1] * 8 - 1 + y, b[2] * 8 - 1 + z];
                let want = if c.iter().all(|&k| (0..n).contains(&k)) {
                    dense[((c[2] * n + c[1]) * n + c[0]) as usize]
                } else {
                    [0.0; 4]
                };
                let p = [slot[0] * 9 + x, slot[1] * 9 + y, slot[2] * 9 + z];
                let got = pooled[((p[2] * ext[1] + p[1]) * ext[0] + p[0]) as usize];
                assert_eq!(got, want, "{}: brick {b:?}, apron texel of voxel {c:?}", img.name);
                checked += 1;
                nonzero += usize::from(want != [0.0; 4]);
            }
        }
        eprintln!("{}: {checked} apron texels, {nonzero} non-zero", img.name);
        assert!(nonzero > 100, "{}: the aprons hold the surfaces' radiance ({nonzero} texels)", img.name);
    }
    assert_no_validation_messages(&ctx);
}

/// The bricked layout's image against the dense one's: FLIP at most 0.005 and the mean
/// radiance within 0.5%.
fn assert_same_image(label: &str, bricks: &dvsgi::metrics::LinearImage, dense: &dvsgi::metrics::LinearImage) {
    let c = dvsgi::metrics::compare(bricks, dense, 0.0, ToneMap::Aces).unwrap();
    let mean = |i: &dvsgi::metrics::LinearImage| i.rgb.iter().map(|&v| f64::from(v)).sum::<f64>();
    let ratio = mean(bricks) / mean(dense);
    eprintln!("{label}: FLIP {:.5}, mean ratio {ratio:.6}", c.flip.mean);
    assert!(c.flip.mean <= 0.005 && (ratio - 1.0).abs() < 0.005, "{label}: FLIP {}, ratio {ratio}", c.flip.mean);
}

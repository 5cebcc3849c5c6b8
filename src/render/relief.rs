//! Height maps on the GPU. Each is uploaded as the normal map of the relief a material gives
//! it (scene::maps::normals_from_heights), so that its mip chain holds the mean of those very
//! normals and a filtered read is the footprint's average at any relief (scaling a mean
//! normal's slopes afterwards is not: 2.2x too bright at `-bm 100` on bump-test, measured).
//! A height map that two materials use with two reliefs is uploaded twice.
//!
//! A relief in texture space (`Relief::Tile`) is exact everywhere. One in scene units
//! (`Relief::Units`) is a relief in tiles that depends on the surface's scene units per unit
//! of UV: the map is uploaded for the material's mean over its triangles, and the shaders
//! scale the slopes by the ratio where a surface's UVs are denser or sparser than that mean
//! (exact at a point; an approximation of the footprint's mean where the ratio is not 1).

use crate::scene::{Relief, Scene, TextureUse, DEFAULT_RELIEF};

/// One texture as the GPU holds it: a scene texture, and for a height map the relief (tiles
/// per unit of height) its normals are made for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureUpload {
    pub texture: u32,
    pub relief: f32,
}

/// The textures to upload (the scene's, in order, then further reliefs of height maps) and,
/// per material, the slot of its normal or height map with the factor the shaders apply
/// (`GpuMaterial::emission.a`, glsl/include/material.glsl `scale_relief`).
#[derive(Debug, Clone, PartialEq)]
pub struct ReliefPlan {
    pub uploads: Vec<TextureUpload>,
    pub normal_maps: Vec<Option<(u32, f32)>>,
}

impl ReliefPlan {
    pub fn of(scene: &Scene) -> ReliefPlan {
        let mut uploads: Vec<TextureUpload> =
            (0..scene.textures.len() as u32).map(|texture| TextureUpload { texture, relief: DEFAULT_RELIEF }).collect();
        let mut claimed = vec![false; scene.textures.len()];
        let mut normal_maps = Vec::with_capacity(scene.materials.len());
        for (mi, m) in scene.materials.iter().enumerate() {
            let Some(t) = m.normal_texture else {
                normal_maps.push(None);
                continue;
            };
            if scene.textures[t as usize].usage != TextureUse::Height {
                normal_maps.push(Some((t, 1.0)));
                continue;
            }
            // Tiles per unit height, and what the shader divides by a surface's scene units
            // per unit of UV (the material's mean: 1 there) for a relief in scene units.
            let (relief, factor) = match m.relief {
                Relief::Tile(k) => (k * DEFAULT_RELIEF, 1.0),
                Relief::Units(u) => match uv_scale(scene, mi as u32) {
                    Some(a) if u != 0.0 => (u / a, a),
                    _ => (0.0, 1.0),
                },
            };
            let wanted = TextureUpload { texture: t, relief };
            let slot = if !claimed[t as usize] {
                claimed[t as usize] = true;
                uploads[t as usize] = wanted;
                t
            } else if let Some(i) = uploads.iter().position(|u| *u == wanted) {
                i as u32
            } else {
                uploads.push(wanted);
                uploads.len() as u32 - 1
            };
            normal_maps.push(Some((slot, factor)));
        }
        ReliefPlan { uploads, normal_maps }
    }
}

/// A material's scene units per unit of UV: sqrt(world area / UV area) over its triangles in
/// every object that places them (None without a triangle of non-degenerate UVs).
pub fn uv_scale(scene: &Scene, material: u32) -> Option<f32> {
    let (mut world, mut uv) = (0.0f64, 0.0f64);
    for o in &scene.objects {
        for &mi in &o.meshes {
            let mesh = &scene.meshes[mi as usize];
            if mesh.material != material || mesh.uvs.len() != mesh.positions.len() {
                continue;
            }
            for tri in mesh.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| tri[k] as usize);
                let p = [a, b, c].map(|i| o.transform.transform_point3(mesh.positions[i]));
                let t = [a, b, c].map(|i| mesh.uvs[i]);
                let area_uv = f64::from((t[1] - t[0]).perp_dot(t[2] - t[0]).abs());
                if area_uv > 1e-12 {
                    uv += area_uv;
                    world += f64::from((p[1] - p[0]).cross(p[2] - p[0]).length());
                }
            }
        }
    }
    (uv > 0.0 && world > 0.0).then(|| (world / uv).sqrt() as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Aabb, Material, Mesh, Motion, Object, Texture};
    use glam::{Mat4, Vec2, Vec3};

    /// A 2 x 2 square over UVs 0..1, one material.
    fn quad_scene() -> Scene {
        let mut s = crate::render::test_scene(vec![]);
        let v = Vec3::new;
        s.meshes.push(Mesh {
            name: "quad".into(),
            positions: vec![v(0., 0., 0.), v(2., 0., 0.), v(2., 2., 0.), v(0., 2., 0.)],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::new(0., 0.), Vec2::new(1., 0.), Vec2::new(1., 1.), Vec2::new(0., 1.)],
            indices: vec![0, 1, 2, 0, 2, 3],
            material: 0,
            bounds: Aabb { min: Vec3::ZERO, max: v(2., 2., 0.) },
        });
        s.objects.push(Object {
            name: "quad".into(),
            meshes: vec![0],
            transform: Mat4::IDENTITY,
            dynamic: false,
            motion: Motion::None,
        });
        s.materials.push(Material::diffuse("m", Vec3::ONE));
        s
    }

    fn height(name: &str) -> Texture {
        Texture { path: name.into(), width: 1, height: 1, rgba8: vec![0; 4], usage: TextureUse::Height }
    }

    #[test]
    fn each_relief_of_a_height_map_gets_its_own_upload() {
        let mut scene = quad_scene();
        scene.textures = vec![height("a"), height("b")];
        let bumped = |name: &str, t: u32, relief: Relief| Material {
            normal_texture: Some(t),
            relief,
            ..Material::diffuse(name, Vec3::ONE)
        };
        scene.materials = vec![
            bumped("default", 0, Relief::Tile(1.0)),
            bumped("twice", 0, Relief::Tile(2.0)),
            bumped("again", 0, Relief::Tile(1.0)),
            bumped("other", 1, Relief::Tile(3.0)),
            Material::diffuse("plain", Vec3::ONE),
        ];
        let plan = ReliefPlan::of(&scene);
        let up = |texture, k: f32| TextureUpload { texture, relief: k * DEFAULT_RELIEF };
        assert_eq!(plan.uploads, [up(0, 1.0), up(1, 3.0), up(0, 2.0)]);
        assert_eq!(plan.normal_maps, [Some((0, 1.0)), Some((2, 1.0)), Some((0, 1.0)), Some((1, 1.0)), None]);
    }

    #[test]
    fn a_relief_in_scene_units_is_made_for_the_materials_uv_density() {
        // The quad spans 2 x 2 units over UVs 0..1: 2 units per unit of UV.
        let mut scene = quad_scene();
        scene.textures = vec![height("a")];
        scene.materials[0].normal_texture = Some(0);
        scene.materials[0].relief = Relief::Units(0.1);
        assert_eq!(uv_scale(&scene, 0), Some(2.0));
        let plan = ReliefPlan::of(&scene);
        assert!((plan.uploads[0].relief - 0.05).abs() < 1e-7, "{:?}", plan.uploads);
        assert_eq!(plan.normal_maps[0], Some((0, 2.0)));
    }
}

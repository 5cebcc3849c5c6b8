//! How much the scene's triangles can occupy, at most, from one walk over every triangle: the
//! voxels of the work list and the bricks of each pool. The work list and the pools are
//! allocated this large, so no voxelization can overflow them; and since both counts come from
//! the same walk (the same triangles, transforms and motion bounds), they cannot disagree.

use super::bricks::BRICK;
use super::grid::VoxelGrid;
use crate::scene::Scene;
use glam::Vec3;

/// Upper bounds of what voxelization can fill.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Capacity {
    /// Voxels the triangles can occupy (the work list's entries), at most N^3.
    pub list: u64,
    /// With bricks: the resident bricks of each pool, pool 0 (full resolution) then the pooled
    /// directional levels; empty without.
    pub bricks: Vec<u64>,
}

/// The bricks walked so far: pool 0's (with aprons), the occupied full-resolution bricks (for
/// the directional levels) and the moving triangles' bricks per pool.
struct BrickCount {
    side0: u32,
    full: Vec<bool>,
    full_apron: Vec<bool>,
    moving: Vec<u64>,
}

impl Capacity {
    /// Walk every triangle of `scene` on `grid`; `levels`: with bricks, the pooled directional
    /// levels (None: dense volumes, no bricks counted).
    ///
    /// The work list: per triangle, the voxels its bounding box touches (conservatively: a box
    /// touching a voxel's face counts); for an object with motion, of any box its triangle can
    /// have once rotated and scaled by up to the motion's largest scale (a cube as wide as the
    /// triangle's enclosing sphere, 2/sqrt(3) of its longest edge). Capped at N^3: the list
    /// follows the surfaces, not the grid.
    ///
    /// The bricks: a static triangle counts the bricks whose 9^3 texels (apron included) it
    /// touches (the separating-axis test against each brick box of its bounding box, grown by
    /// 1/64 voxel so that the voxelizer's conservative coverage is inside); a moving one, the
    /// bricks of the same cube wherever it goes. A directional texel is needed by the brick
    /// holding it and by the brick whose apron holds it.
    pub fn of(scene: &Scene, grid: &VoxelGrid, levels: Option<u32>) -> Capacity {
        let n = grid.resolution;
        let vs = grid.voxel_size.max(f32::MIN_POSITIVE);
        let mut bricks = levels.map(|l| BrickCount::new(n, l));
        let mut list = 0u64;
        for o in &scene.objects {
            let moves = !o.motion.is_static();
            let m = o.model_matrix(scene.settings.time);
            let scale = object_max_scale(o);
            for mesh in o.meshes.iter().filter_map(|&i| scene.meshes.get(i as usize)) {
                for t in mesh.indices.chunks_exact(3) {
                    let p = [t[0], t[1], t[2]].map(|i| mesh.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO));
                    if moves {
                        let side = swept_cube_side(p, scale) / vs; // voxels
                        list = list.saturating_add(moving_voxels(side, n));
                        bricks.iter_mut().for_each(|b| b.add_moving(side));
                    } else {
                        let w = p.map(|q| (m.transform_point3(q) - grid.origin) / vs);
                        list = list.saturating_add(static_voxels(w, n));
                        bricks.iter_mut().for_each(|b| b.add_static(w));
                    }
                }
            }
        }
        Capacity { list: list.min(u64::from(n).pow(3)), bricks: bricks.map_or(Vec::new(), |b| b.pools(n)) }
    }
}

/// Voxels of the box of a cube `side` voxels wide, wherever it goes (a moving triangle).
fn moving_voxels(side: f32, n: u32) -> u64 {
    let n = u64::from(n);
    let side = side.min(n as f32);
    ((side + 0.02).floor() as u64 + 2).min(n).pow(3)
}

/// Voxels the bounding box of triangle `w` (voxel units) touches, inside the grid.
fn static_voxels(w: [Vec3; 3], n: u32) -> u64 {
    let n = u64::from(n);
    // Voxels along one axis touched by the span [lo, hi], inside the grid.
    let span = |lo: f32, hi: f32| -> u64 {
        let (lo, hi) = (lo.max(0.0) - 0.01, hi.min(n as f32) + 0.01);
        if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
            return 0;
        }
        ((hi.floor() - lo.ceil()) as i64 + 2).clamp(0, n as i64) as u64
    };
    let (lo, hi) = (w[0].min(w[1]).min(w[2]), w[0].max(w[1]).max(w[2]));
    span(lo.x, hi.x) * span(lo.y, hi.y) * span(lo.z, hi.z)
}

impl BrickCount {
    fn new(n: u32, levels: u32) -> BrickCount {
        let side0 = n / BRICK;
        BrickCount {
            side0,
            full: vec![false; (side0 as usize).pow(3)],
            full_apron: vec![false; (side0 as usize + 1).pow(3)],
            moving: vec![0u64; levels as usize + 1],
        }
    }

    /// A moving triangle within a cube `side` voxels wide: its bricks in every pool.
    fn add_moving(&mut self, side: f32) {
        for (l, count) in self.moving.iter_mut().enumerate() {
            // Texels of this pool's level per voxel, and its bricks per axis. Pool 0's apron
            // reaches one voxel further down.
            let (texel, apron) = if l == 0 { (1.0, 1.0) } else { ((1u32 << l) as f32, 0.0) };
            let bricks = ((side / texel + 2.0 + apron) / BRICK as f32).ceil() as u64 + 1;
            *count += bricks.pow(3);
        }
    }

    /// A static triangle `w` (voxel units): the bricks it touches.
    fn add_static(&mut self, w: [Vec3; 3]) {
        mark_triangle_bricks(&mut self.full, self.side0, w, 0);
        mark_triangle_bricks(&mut self.full_apron, self.side0 + 1, w, 1);
    }

    /// Pool 0's bricks, then each directional level's.
    fn pools(&self, n: u32) -> Vec<u64> {
        let mut caps = vec![self.full_apron.iter().filter(|&&b| b).count() as u64 + self.moving[0]];
        for l in 0..self.moving.len() as u32 - 1 {
            caps.push(directional_bricks(&self.full, self.side0, n, l) + self.moving[l as usize + 1]);
        }
        caps
    }
}

/// Mark the bricks (of `side`^3) that triangle `w` (voxel units) touches; with `apron` 1, a
/// brick b spans voxels 8b - 1 .. 8b + 8 (its apron below it included).
fn mark_triangle_bricks(bricks: &mut [bool], side: u32, w: [Vec3; 3], apron: u32) {
    let b = BRICK as f32;
    let a = apron as f32;
    let lo = (w[0].min(w[1]).min(w[2]) / b).floor().max(Vec3::ZERO);
    let hi = ((w[0].max(w[1]).max(w[2]) + a) / b).floor().min(Vec3::splat(side as f32 - 1.0));
    if lo.cmpgt(hi).any() {
        return;
    }
    let grow = 1.0 / 64.0;
    for z in lo.z as u32..=hi.z as u32 {
        for y in lo.y as u32..=hi.y as u32 {
            for x in lo.x as u32..=hi.x as u32 {
                let i = (x + side * (y + side * z)) as usize;
                if bricks[i] {
                    continue;
                }
                let centre = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * b - 0.5 * a;
                if triangle_box_overlap(centre, Vec3::splat((b + a) * 0.5 + grow), w) {
                    bricks[i] = true;
                }
            }
        }
    }
}

/// Bricks of directional level `l` that a full-resolution brick set can make non-empty: the
/// texels under each full-resolution brick, each in its own brick and in the apron of the
/// next brick up on each axis.
fn directional_bricks(full: &[bool], side0: u32, n: u32, l: u32) -> u64 {
    let level_side = (n / 2) >> l;
    let map_side = level_side / BRICK + 1;
    let mut set = vec![false; (map_side as usize).pow(3)];
    let shift = l + 1; // full-resolution voxels per texel: 2^shift
    for (i, _) in full.iter().enumerate().filter(|(_, &b)| b) {
        let i = i as u32;
        let b = [i % side0, (i / side0) % side0, i / (side0 * side0)];
        // Texels lo..=hi under the brick, then the bricks of lo..=hi+1.
        let range = b.map(|c| ((c * BRICK) >> shift, (((c * BRICK + BRICK - 1) >> shift) + 1) / BRICK));
        let first = range.map(|(lo, _)| lo / BRICK);
        for z in first[2]..=range[2].1.min(map_side - 1) {
            for y in first[1]..=range[1].1.min(map_side - 1) {
                for x in first[0]..=range[0].1.min(map_side - 1) {
                    set[(x + map_side * (y + map_side * z)) as usize] = true;
                }
            }
        }
    }
    set.iter().filter(|&&b| b).count() as u64
}

/// Separating-axis test of a triangle against the box at `c` with half size `h` (touching
/// counts), as glsl/include/voxel.glsl's.
pub fn triangle_box_overlap(c: Vec3, h: Vec3, t: [Vec3; 3]) -> bool {
    let v = t.map(|p| p - c);
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let separates = |axis: Vec3| {
        let len2 = axis.length_squared();
        if len2 < 1e-20 {
            return false;
        }
        let p = v.map(|q| axis.dot(q));
        let r = h.dot(axis.abs());
        let eps = 1e-5 * (r + 1e-3 * len2.sqrt());
        p[0].min(p[1]).min(p[2]) > r + eps || p[0].max(p[1]).max(p[2]) < -r - eps
    };
    let axes = [Vec3::X, Vec3::Y, Vec3::Z];
    if axes.iter().any(|&a| separates(a)) || separates(e[0].cross(e[1])) {
        return false;
    }
    !e.iter().any(|ei| axes.iter().any(|&a| separates(ei.cross(a))))
}

/// The side (object units times `scale`) of a cube that holds triangle `p` however it is
/// rotated and scaled by up to `scale`: as wide as the enclosing sphere of the triangle,
/// 2/sqrt(3) of its longest edge.
fn swept_cube_side(p: [Vec3; 3], scale: f32) -> f32 {
    let edge = (p[0] - p[1]).length().max((p[1] - p[2]).length()).max((p[2] - p[0]).length());
    edge * scale * 2.0 / 3f32.sqrt()
}

/// The largest factor by which an object's model matrix can stretch a length at any time
/// (its static transform's, times the largest keyframe scale).
fn object_max_scale(o: &crate::scene::Object) -> f32 {
    let c = [o.transform.x_axis.truncate(), o.transform.y_axis.truncate(), o.transform.z_axis.truncate()];
    let len = c.map(|v| v.length());
    // Translate-rotate-scale (what scene files build) has orthogonal columns: the largest
    // stretch is the longest column. Otherwise the Frobenius norm bounds it.
    let tol = 1e-4 * len[0].max(len[1]).max(len[2]).powi(2);
    let orthogonal = c[0].dot(c[1]).abs() <= tol && c[1].dot(c[2]).abs() <= tol && c[0].dot(c[2]).abs() <= tol;
    let fixed = if orthogonal { len[0].max(len[1]).max(len[2]) } else { len.map(|l| l * l).iter().sum::<f32>().sqrt() };
    let motion = match &o.motion {
        crate::scene::Motion::Keyframes(k) => k.iter().map(|k| k.scale.abs().max_element()).fold(1.0f32, f32::max),
        _ => 1.0,
    };
    fixed * motion
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Aabb, Keyframe, Mesh, Motion, Object};
    use glam::Mat4;

    /// The test scene's grid [0, 2]^3 at 8^3 (voxels of 0.25) holding one triangle.
    fn one_triangle(tri: [Vec3; 3], motion: Motion) -> (Scene, VoxelGrid) {
        let mut s = crate::render::test_scene(vec![]);
        s.settings.gi.voxel_resolution = 8;
        s.meshes.push(Mesh {
            name: "t".into(),
            positions: tri.to_vec(),
            normals: vec![Vec3::Y; 3],
            uvs: vec![glam::Vec2::ZERO; 3],
            indices: vec![0, 1, 2],
            material: 0,
            bounds: Aabb::EMPTY,
        });
        s.objects.push(Object { name: "o".into(), meshes: vec![0], transform: Mat4::IDENTITY, dynamic: true, motion });
        let g = VoxelGrid::for_scene(&s);
        (s, g)
    }

    #[test]
    fn a_full_resolution_brick_needs_the_directional_bricks_of_its_texels_and_aprons() {
        // Grid 256: level 0 has 128 texels per side, map 17. Full-res brick (1, 0, 0) covers
        // voxels 8..15 -> texels 4..7 -> bricks 0 and (7 + 1) / 8 = 1 along x; along y and z
        // brick 0 covers texels 0..3 -> brick 0 only.
        let side0 = 32;
        let mut full = vec![false; 32 * 32 * 32];
        full[1] = true;
        assert_eq!(directional_bricks(&full, side0, 256, 0), 2);
        // Brick (0, 0, 0): texels 0..3, brick 0 only.
        let mut full = vec![false; 32 * 32 * 32];
        full[0] = true;
        assert_eq!(directional_bricks(&full, side0, 256, 0), 1);
    }

    #[test]
    fn a_triangle_marks_the_bricks_it_crosses() {
        let side = 4; // a 32^3 grid
        let mut bricks = vec![false; 64];
        // A horizontal triangle at y = 4 (inside brick row 0) over x, z in [1, 20].
        let v = Vec3::new;
        mark_triangle_bricks(&mut bricks, side, [v(1.0, 4.0, 1.0), v(20.0, 4.0, 1.0), v(1.0, 4.0, 20.0)], 0);
        let marked: Vec<usize> = (0..64).filter(|&i| bricks[i]).collect();
        // x, z bricks 0..2 below the diagonal x + z <= 21: (0,0) (1,0) (2,0) (0,1) (1,1) (0,2)
        // (brick (2,1) starts at x = 16, z = 8: 24 > 21; (1,2): x = 8, z = 16: 24 > 21).
        let expect: Vec<usize> = [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (0, 2)]
            .iter()
            .map(|&(x, z)| x + side as usize * side as usize * z)
            .collect();
        let mut expect = expect;
        expect.sort();
        assert_eq!(marked, expect);
    }

    #[test]
    fn a_brick_with_an_apron_is_marked_by_the_last_voxels_of_the_brick_below() {
        // A 32^3 grid; pool 0's map has 4 + 1 bricks per side. A wall in the plane x = 7.5
        // fills voxels x = 7, the last of brick 0 along x: brick 1's apron holds them.
        let v = Vec3::new;
        let wall = [v(7.5, 1.0, 1.0), v(7.5, 6.0, 1.0), v(7.5, 1.0, 6.0)];
        let mut plain = vec![false; 64];
        mark_triangle_bricks(&mut plain, 4, wall, 0);
        assert_eq!(plain.iter().filter(|&&b| b).count(), 1);
        let mut apron = vec![false; 125];
        mark_triangle_bricks(&mut apron, 5, wall, 1);
        let marked: Vec<usize> = (0..125).filter(|&i| apron[i]).collect();
        assert_eq!(marked, vec![0, 1], "brick (0, 0, 0) and the one above it along x");
        // At x = 4.5 (voxel 4, inside brick 0) no apron holds it.
        let mut apron = vec![false; 125];
        mark_triangle_bricks(&mut apron, 5, [v(4.5, 1.0, 1.0), v(4.5, 6.0, 1.0), v(4.5, 1.0, 6.0)], 1);
        assert_eq!((0..125).filter(|&i| apron[i]).collect::<Vec<_>>(), vec![0]);
    }

    #[test]
    fn list_capacity_bounds_the_voxels_a_triangle_can_touch() {
        let v = Vec3::new;
        // A horizontal triangle at y = 1.1 over x, z in [0.1, 0.9] (voxels 0..3): 4 x 1 x 4
        // voxels of its box, plus the neighbours its box touches within 0.01 voxel (none here).
        let tri = [v(0.1, 1.1, 0.1), v(0.9, 1.1, 0.1), v(0.1, 1.1, 0.9)];
        let (s, g) = one_triangle(tri, Motion::None);
        assert_eq!(Capacity::of(&s, &g, None).list, 4 * 1 * 4);
        // On a voxel face (y = 1.0) it touches both layers.
        let (s, g) = one_triangle(tri.map(|p| v(p.x, 1.0, p.z)), Motion::None);
        assert_eq!(Capacity::of(&s, &g, None).list, 4 * 2 * 4);
        // Moving (and scaled up to 2 by a keyframe): a cube as wide as the enclosing sphere of
        // the triangle twice as large, whatever its orientation: 0.8 * sqrt(2) * 2 * 2/sqrt(3)
        // = 2.61 m = 10.5 voxels, capped at the 8 voxels of the grid: 8^3.
        let key = |scale: f32| Keyframe {
            time: 0.0,
            translate: Vec3::ZERO,
            rotate_deg: Vec3::ZERO,
            scale: Vec3::splat(scale),
        };
        let (s, g) = one_triangle(tri, Motion::Keyframes(vec![key(1.0), key(2.0)]));
        assert_eq!(Capacity::of(&s, &g, None).list, 512);
        // At scale 1: 1.31 m = 5.2 voxels, so 7 per axis.
        let (s, g) = one_triangle(tri, Motion::Keyframes(vec![key(1.0)]));
        assert_eq!(Capacity::of(&s, &g, None).list, 7 * 7 * 7);
        // Outside the grid: nothing.
        let (s, g) = one_triangle(tri.map(|p| p + Vec3::splat(10.0)), Motion::None);
        assert_eq!(Capacity::of(&s, &g, None).list, 0);
    }
}

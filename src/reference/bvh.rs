//! Bounding volume hierarchy for the reference path tracer: built on the host with binned
//! SAH, flattened depth-first (a node's two children are adjacent), traversed on the GPU by
//! `glsl/pt_trace.comp`. The host traversal here is the specification the shader follows
//! and is tested against brute force.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Mirrors `BvhNode` in glsl/pt_trace.comp (std430).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, Default)]
pub struct BvhNode {
    /// xyz box minimum; w (bits): first triangle for a leaf, left child for an inner node.
    pub min: [f32; 4],
    /// xyz box maximum; w (bits): triangle count for a leaf, 0 for an inner node.
    pub max: [f32; 4],
}

impl BvhNode {
    pub fn first(&self) -> u32 {
        self.min[3].to_bits()
    }
    pub fn count(&self) -> u32 {
        self.max[3].to_bits()
    }
    /// A leaf holds triangles, or is the empty root of a scene without any (no inner node
    /// points at node 0, so `first == 0` with no count can only be that).
    pub fn is_leaf(&self) -> bool {
        self.count() > 0 || self.first() == 0
    }
}

/// The flattened tree; `order[i]` is the input triangle stored at position `i`.
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub order: Vec<u32>,
}

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
/// Traversal cost relative to one triangle test, for the SAH.
const TRAVERSAL_COST: f32 = 1.0;
/// Deepest tree the shader's stack holds (its stack has this many entries).
pub const MAX_DEPTH: usize = 48;

#[derive(Clone, Copy)]
struct Bounds {
    min: Vec3,
    max: Vec3,
}

impl Bounds {
    const EMPTY: Bounds = Bounds { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };
    fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    fn union(&mut self, o: &Bounds) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }
    fn area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

struct Prim {
    bounds: Bounds,
    centroid: Vec3,
}

impl Bvh {
    /// Build over triangles given as three corners each.
    pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
        let prims: Vec<Prim> = triangles
            .iter()
            .map(|t| {
                let mut b = Bounds::EMPTY;
                for p in t {
                    b.grow(*p);
                }
                Prim { bounds: b, centroid: (b.min + b.max) * 0.5 }
            })
            .collect();
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut nodes = vec![BvhNode::default()];
        if !order.is_empty() {
            let n = order.len();
            build_node(&prims, &mut order, 0, n, 0, &mut nodes, 0);
        } else {
            // An empty scene: one leaf with no triangles and an empty box rays miss.
            nodes[0] = leaf(Bounds { min: Vec3::splat(1.0), max: Vec3::splat(-1.0) }, 0, 0);
        }
        Bvh { nodes, order }
    }

    /// Closest hit (t, triangle position in `order`) of a ray with the stored triangles,
    /// `tris[i]` being the triangle at position `i`. The same walk as the shader.
    pub fn intersect(&self, tris: &[[Vec3; 3]], origin: Vec3, dir: Vec3, t_max: f32) -> Option<(f32, u32)> {
        let inv = dir.recip();
        let mut best: Option<(f32, u32)> = None;
        let mut t_best = t_max;
        box_hit(&self.nodes[0], origin, inv, t_best)?;
        let mut stack: Vec<(usize, f32)> = Vec::with_capacity(MAX_DEPTH);
        let mut node = 0usize;
        'walk: loop {
            let n = &self.nodes[node];
            if n.is_leaf() {
                for i in n.first()..n.first() + n.count() {
                    if let Some(t) = intersect_triangle(&tris[i as usize], origin, dir) {
                        if t < t_best {
                            t_best = t;
                            best = Some((t, i));
                        }
                    }
                }
            } else {
                let l = n.first() as usize;
                let tl = box_hit(&self.nodes[l], origin, inv, t_best);
                let tr = box_hit(&self.nodes[l + 1], origin, inv, t_best);
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        let (near, far, t_far) = if a <= b { (l, l + 1, b) } else { (l + 1, l, a) };
                        stack.push((far, t_far));
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = l + 1;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            while let Some((next, t_entry)) = stack.pop() {
                if t_entry <= t_best {
                    node = next;
                    continue 'walk;
                }
            }
            break;
        }
        best
    }

    /// Depth of the deepest leaf (the root has depth 0).
    pub fn depth(&self) -> usize {
        fn walk(nodes: &[BvhNode], i: usize) -> usize {
            let n = &nodes[i];
            if n.is_leaf() {
                0
            } else {
                let l = n.first() as usize;
                1 + walk(nodes, l).max(walk(nodes, l + 1))
            }
        }
        walk(&self.nodes, 0)
    }
}

fn leaf(b: Bounds, first: u32, count: u32) -> BvhNode {
    BvhNode {
        min: [b.min.x, b.min.y, b.min.z, f32::from_bits(first)],
        max: [b.max.x, b.max.y, b.max.z, f32::from_bits(count)],
    }
}

/// Build the node at `index` over `order[start..end]`.
fn build_node(
    prims: &[Prim],
    order: &mut [u32],
    start: usize,
    end: usize,
    index: usize,
    nodes: &mut Vec<BvhNode>,
    depth: usize,
) {
    let mut bounds = Bounds::EMPTY;
    let mut cbounds = Bounds::EMPTY;
    for &i in &order[start..end] {
        bounds.union(&prims[i as usize].bounds);
        cbounds.grow(prims[i as usize].centroid);
    }
    let count = end - start;
    let make_leaf = |nodes: &mut Vec<BvhNode>| nodes[index] = leaf(bounds, start as u32, count as u32);
    // Too deep for the shader's stack: keep the rest in one leaf (correct, only slower).
    if count <= MAX_LEAF || depth + 1 >= MAX_DEPTH {
        make_leaf(nodes);
        return;
    }
    let split = sah_split(prims, &order[start..end], &bounds, &cbounds);
    let mid = match split {
        Some((axis, pos)) => {
            let slice = &mut order[start..end];
            let mut m = 0;
            for i in 0..slice.len() {
                if prims[slice[i] as usize].centroid[axis] < pos {
                    slice.swap(i, m);
                    m += 1;
                }
            }
            start + m
        }
        None => start,
    };
    // No useful split (all centroids equal, or SAH says a leaf is cheaper but it is large):
    // split in the middle of the list so leaves stay small.
    let mid = if mid == start || mid == end {
        if split.is_none() && count <= 2 * MAX_LEAF {
            make_leaf(nodes);
            return;
        }
        start + count / 2
    } else {
        mid
    };
    let left = nodes.len();
    nodes.push(BvhNode::default());
    nodes.push(BvhNode::default());
    nodes[index] = BvhNode {
        min: [bounds.min.x, bounds.min.y, bounds.min.z, f32::from_bits(left as u32)],
        max: [bounds.max.x, bounds.max.y, bounds.max.z, f32::from_bits(0)],
    };
    build_node(prims, order, start, mid, left, nodes, depth + 1);
    build_node(prims, order, mid, end, left + 1, nodes, depth + 1);
}

/// The best binned-SAH split (axis, centroid position), or `None` when a leaf is cheaper.
fn sah_split(prims: &[Prim], items: &[u32], bounds: &Bounds, cbounds: &Bounds) -> Option<(usize, f32)> {
    let mut best: Option<(f32, usize, f32)> = None;
    let extent = cbounds.max - cbounds.min;
    for axis in 0..3 {
        if extent[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            continue;
        }
        let mut bins = [(Bounds::EMPTY, 0u32); BINS];
        let scale = BINS as f32 / extent[axis];
        let bin_of = |c: f32| (((c - cbounds.min[axis]) * scale) as usize).min(BINS - 1);
        for &i in items {
            let p = &prims[i as usize];
            let b = &mut bins[bin_of(p.centroid[axis])];
            b.0.union(&p.bounds);
            b.1 += 1;
        }
        // Sweep from the right for suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let mut acc = Bounds::EMPTY;
        let mut n = 0;
        for k in (1..BINS).rev() {
            acc.union(&bins[k].0);
            n += bins[k].1;
            right_area[k] = acc.area();
            right_count[k] = n;
        }
        let mut acc = Bounds::EMPTY;
        let mut n = 0;
        for k in 0..BINS - 1 {
            acc.union(&bins[k].0);
            n += bins[k].1;
            if n == 0 || right_count[k + 1] == 0 {
                continue;
            }
            let cost = acc.area() * n as f32 + right_area[k + 1] * right_count[k + 1] as f32;
            if best.map_or(true, |b| cost < b.0) {
                let pos = cbounds.min[axis] + (k + 1) as f32 / scale;
                best = Some((cost, axis, pos));
            }
        }
    }
    let (cost, axis, pos) = best?;
    let area = bounds.area().max(f32::MIN_POSITIVE);
    let split_cost = TRAVERSAL_COST + cost / area;
    let leaf_cost = items.len() as f32;
    (split_cost < leaf_cost || items.len() > MAX_LEAF).then_some((axis, pos))
}

/// Slab test: the entry distance if the ray meets the box before `t_max`.
fn box_hit(n: &BvhNode, o: Vec3, inv: Vec3, t_max: f32) -> Option<f32> {
    let lo = (Vec3::new(n.min[0], n.min[1], n.min[2]) - o) * inv;
    let hi = (Vec3::new(n.max[0], n.max[1], n.max[2]) - o) * inv;
    let t0 = lo.min(hi).max_element().max(0.0);
    let t1 = lo.max(hi).min_element().min(t_max);
    (t0 <= t1).then_some(t0)
}

/// The watertight ray-triangle test (Woop, Benthin and Wald, JCGT 2013), as `hit_triangle` in
/// glsl/pt_trace.comp: the hit distance if positive. Both faces count; a ray through an edge
/// two triangles share hits at least one of them.
pub fn intersect_triangle(t: &[Vec3; 3], o: Vec3, d: Vec3) -> Option<f32> {
    let a = d.abs();
    let kz = if a.x > a.y && a.x > a.z {
        0
    } else if a.y > a.z {
        1
    } else {
        2
    };
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let shear = Vec3::new(-d[kx] / d[kz], -d[ky] / d[kz], 1.0 / d[kz]);
    let sheared = |v: Vec3| {
        let a = v - o;
        Vec3::new(a[kx] + shear.x * a[kz], a[ky] + shear.y * a[kz], shear.z * a[kz])
    };
    let [a, b, c] = t.map(sheared);
    let u = c.x * b.y - c.y * b.x;
    let v = a.x * c.y - a.y * c.x;
    let w = b.x * a.y - b.y * a.x;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t = (u * a.z + v * b.z + w * c.z) / det;
    (t > 0.0).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic generator for test geometry (xorshift).
    struct Rng(u64);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
        fn v(&mut self) -> Vec3 {
            Vec3::new(self.f(), self.f(), self.f())
        }
    }

    fn soup(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
        let mut r = Rng(seed);
        (0..n)
            .map(|_| {
                let c = r.v() * 10.0;
                [c, c + (r.v() - 0.5), c + (r.v() - 0.5)]
            })
            .collect()
    }

    #[test]
    fn closest_hit_matches_brute_force() {
        let tris = soup(2000, 7);
        let bvh = Bvh::build(&tris);
        let stored: Vec<[Vec3; 3]> = bvh.order.iter().map(|&i| tris[i as usize]).collect();
        // Every triangle appears exactly once.
        let mut seen = bvh.order.clone();
        seen.sort();
        assert_eq!(seen, (0..2000).collect::<Vec<u32>>());
        assert!(bvh.depth() < MAX_DEPTH, "depth {}", bvh.depth());
        let mut r = Rng(99);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = r.v() * 14.0 - 2.0;
            let d = (r.v() - 0.5).normalize();
            let brute = stored
                .iter()
                .enumerate()
                .filter_map(|(i, t)| intersect_triangle(t, o, d).map(|t| (t, i as u32)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let got = bvh.intersect(&stored, o, d, f32::INFINITY);
            assert_eq!(got.map(|g| g.1), brute.map(|b| b.1), "ray {o} {d}");
            hits += got.is_some() as u32;
        }
        assert!(hits > 200, "only {hits} rays hit: the test says little");
    }

    #[test]
    fn leaves_cover_every_triangle_and_boxes_contain_them() {
        let tris = soup(500, 3);
        let bvh = Bvh::build(&tris);
        let mut covered = vec![0u32; tris.len()];
        for n in &bvh.nodes {
            if n.count() > 0 {
                assert!(n.count() as usize <= 2 * MAX_LEAF);
                for i in n.first()..n.first() + n.count() {
                    covered[i as usize] += 1;
                    for p in tris[bvh.order[i as usize] as usize] {
                        for k in 0..3 {
                            assert!(p[k] >= n.min[k] && p[k] <= n.max[k]);
                        }
                    }
                }
            }
        }
        assert!(covered.iter().all(|&c| c == 1));
    }

    #[test]
    fn degenerate_inputs_build() {
        // Empty (its root box is inverted, which a slab test still enters), one triangle, many identical triangles (no centroid spread), a zero-area one.
        assert!(Bvh::build(&[]).intersect(&[], Vec3::ZERO, Vec3::X, f32::INFINITY).is_none());
        let one = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
        let b = Bvh::build(&one);
        assert_eq!(b.intersect(&one, Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, f32::INFINITY).map(|h| h.1), Some(0));
        let same = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 100];
        let b = Bvh::build(&same);
        assert!(b.depth() < MAX_DEPTH);
        assert!(b.intersect(&same, Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, f32::INFINITY).is_some());
        let flat = [[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]];
        assert!(Bvh::build(&flat).intersect(&flat, Vec3::new(0.5, 0.0, 1.0), -Vec3::Z, f32::INFINITY).is_none());
    }

    /// Rays aimed at points of the edge two triangles share (a quad's diagonal, tilted, off
    /// the origin) hit one of them, every one; rays just past the quad's outer edges miss.
    #[test]
    fn rays_through_a_shared_edge_never_pass_between_the_triangles() {
        let mut r = Rng(7);
        for _ in 0..200 {
            let base = r.v() * 20.0 - 10.0;
            let (u, v) = (r.v() * 3.0 + Vec3::splat(0.1), r.v() * 3.0 + Vec3::splat(0.1));
            let quad = [base, base + u, base + u + v, base + v];
            let tris = [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]];
            for _ in 0..50 {
                let on_edge = quad[0].lerp(quad[2], r.f());
                let o = on_edge + (r.v() - 0.5).normalize() * (1.0 + 10.0 * r.f());
                let d = on_edge - o;
                let hits = tris.iter().filter(|t| intersect_triangle(t, o, d).is_some()).count();
                assert!(hits >= 1, "a ray from {o} through {on_edge} on the shared edge passed between");
            }
        }
        let one = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(intersect_triangle(&one, Vec3::new(-1e-3, 0.5, 1.0), -Vec3::Z).is_none());
        assert!(intersect_triangle(&one, Vec3::new(0.5, 0.5 + 1e-3, 1.0), -Vec3::Z).is_none());
        assert_eq!(intersect_triangle(&one, Vec3::new(0.25, 0.25, 2.0), -Vec3::Z), Some(2.0));
    }
}

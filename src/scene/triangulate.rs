//! Polygon faces to triangles by ear clipping in the face's own plane.
//!
//! OBJ faces may have any number of vertices and may be concave. A fan from the first vertex
//! (what tobj does) covers area outside a concave polygon and inverts triangles; ear clipping
//! never does for a simple polygon. The ear search starts at the second vertex, so a convex
//! face gives exactly the fan it always did (the same diagonals for the slightly non-planar
//! quads of the Cornell box data): only faces a fan gets wrong change. Non-planar faces are clipped in their best-fit (Newell)
//! plane. Degenerate faces (no area) and self-intersecting ones, where no ear exists, fall
//! back to a fan of what is left, so every face still yields n - 2 triangles.

use glam::{DVec2, DVec3, Vec3};

/// Triangle indices for faces given by `indices` with per-face vertex counts `arities` (as
/// tobj reports them; empty when every face is a triangle).
pub(crate) fn triangulate_faces(positions: &[Vec3], indices: &[u32], arities: &[u32]) -> Vec<u32> {
    if arities.is_empty() {
        return indices.to_vec();
    }
    let mut out = Vec::with_capacity(indices.len() * 3);
    let mut start = 0usize;
    for &n in arities {
        let n = n as usize;
        let Some(face) = indices.get(start..start + n) else { break };
        start += n;
        if n < 3 {
            continue;
        }
        let points: Vec<DVec3> =
            face.iter().map(|&i| positions.get(i as usize).copied().unwrap_or(Vec3::ZERO).as_dvec3()).collect();
        for t in triangulate_polygon(&points) {
            out.extend(t.iter().map(|&k| face[k]));
        }
    }
    out
}

/// Triangles (as indices into `points`) covering the polygon `points`, wound like it.
pub(crate) fn triangulate_polygon(points: &[DVec3]) -> Vec<[usize; 3]> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    if n == 3 {
        return vec![[0, 1, 2]];
    }
    let normal = newell_normal(points);
    if !(normal.length_squared() > 0.0) || !normal.is_finite() {
        return fan(&(0..n).collect::<Vec<_>>());
    }
    let flat = project(points, normal);
    ear_clip(&flat)
}

/// The polygon's area-weighted normal (Newell's method): robust for non-planar polygons.
fn newell_normal(p: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, a) in p.iter().enumerate() {
        let b = p[(i + 1) % p.len()];
        n += DVec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    n
}

/// The points in 2D coordinates of the plane with `normal`, so that the polygon winds
/// counter-clockwise there.
fn project(points: &[DVec3], normal: DVec3) -> Vec<DVec2> {
    let n = normal.normalize();
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    points.iter().map(|p| DVec2::new(p.dot(u), p.dot(v))).collect()
}

fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
    (a - o).perp_dot(b - o)
}

/// Whether `p` lies inside or on the counter-clockwise triangle `a b c`.
fn in_triangle(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0
}

/// Ear clipping of a counter-clockwise polygon; O(n^2) per face, fine for OBJ faces. Ears
/// are tried from the second remaining vertex on, so a convex polygon is cut as the fan
/// (0 1 2), (0 2 3), ...
fn ear_clip(p: &[DVec2]) -> Vec<[usize; 3]> {
    let mut left: Vec<usize> = (0..p.len()).collect();
    let mut out = Vec::with_capacity(p.len() - 2);
    while left.len() > 3 {
        let m = left.len();
        let ear = (1..m).chain(std::iter::once(0)).find(|&i| {
            let (a, b, c) = (left[(i + m - 1) % m], left[i], left[(i + 1) % m]);
            cross(p[a], p[b], p[c]) > 0.0
                && !left.iter().any(|&k| {
                    // Another vertex in or on the ear (a repeated position counts only if
                    // it is not one of the ear's own corners).
                    k != a && k != b && k != c && p[k] != p[a] && p[k] != p[c] && in_triangle(p[k], p[a], p[b], p[c])
                })
        });
        let Some(i) = ear else {
            // Self-intersecting or numerically degenerate: no ear. Fan what is left.
            out.extend(fan(&left));
            return out;
        };
        out.push([left[(i + m - 1) % m], left[i], left[(i + 1) % m]]);
        left.remove(i);
    }
    out.push([left[0], left[1], left[2]]);
    out
}

fn fan(v: &[usize]) -> Vec<[usize; 3]> {
    (1..v.len().saturating_sub(1)).map(|i| [v[0], v[i], v[i + 1]]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area_and_inverted(points: &[DVec3], tris: &[[usize; 3]]) -> (f64, usize) {
        let normal = newell_normal(points).normalize();
        let mut area = 0.0;
        let mut inverted = 0;
        for t in tris {
            let n = (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]);
            area += n.length() / 2.0;
            if n.dot(normal) < 0.0 {
                inverted += 1;
            }
        }
        (area, inverted)
    }

    fn xy(v: &[(f64, f64)]) -> Vec<DVec3> {
        v.iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect()
    }

    /// Shoelace area of a planar polygon in the xy plane.
    fn shoelace(v: &[DVec3]) -> f64 {
        (0..v.len()).map(|i| v[i].x * v[(i + 1) % v.len()].y - v[(i + 1) % v.len()].x * v[i].y).sum::<f64>().abs() / 2.0
    }

    #[test]
    fn convex_faces_keep_their_area_and_winding() {
        let square = xy(&[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]);
        let t = triangulate_polygon(&square);
        assert_eq!(t.len(), 2);
        assert_eq!(area_and_inverted(&square, &t), (1.0, 0));
        // Clockwise: the triangles wind clockwise too (the face's normal is kept).
        let cw: Vec<DVec3> = square.iter().rev().copied().collect();
        let t = triangulate_polygon(&cw);
        assert_eq!(area_and_inverted(&cw, &t), (1.0, 0));
        let n = (cw[t[0][1]] - cw[t[0][0]]).cross(cw[t[0][2]] - cw[t[0][0]]);
        assert!(n.z < 0.0, "{n}");
    }

    #[test]
    fn convex_faces_are_cut_as_the_fan_they_always_were() {
        let hex: Vec<DVec3> = (0..6)
            .map(|i| {
                let a = i as f64 / 6.0 * std::f64::consts::TAU;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        assert_eq!(triangulate_polygon(&hex), fan(&(0..6).collect::<Vec<_>>()));
        // A slightly non-planar quad keeps the fan's diagonal (0-2), not the other one.
        let quad = [DVec3::ZERO, DVec3::new(1.0, 0.0, 0.05), DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.0, 1.0, 0.05)];
        assert_eq!(triangulate_polygon(&quad), vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn a_concave_ring_is_covered_exactly() {
        // A 66-vertex star-like ring: radius alternating 1 and 0.3 (deeply concave).
        let ring: Vec<DVec3> = (0..66)
            .map(|i| {
                let a = i as f64 / 66.0 * std::f64::consts::TAU;
                let r = if i % 2 == 0 { 1.0 } else { 0.3 };
                DVec3::new(r * a.cos(), r * a.sin(), 0.0)
            })
            .collect();
        let t = triangulate_polygon(&ring);
        assert_eq!(t.len(), 64);
        let (area, inverted) = area_and_inverted(&ring, &t);
        assert_eq!(inverted, 0);
        assert!((area - shoelace(&ring)).abs() < 1e-9, "{area} against {}", shoelace(&ring));
        // A fan from vertex 0 would cover more than the polygon.
        let f = fan(&(0..66).collect::<Vec<_>>());
        assert!(area_and_inverted(&ring, &f).0 > area * 1.01);
    }

    #[test]
    fn an_l_shape_and_a_comb_are_not_filled_in() {
        let l = xy(&[(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]);
        let t = triangulate_polygon(&l);
        assert_eq!(area_and_inverted(&l, &t), (3.0, 0));
        // Start the fan at the reflex vertex's neighbour: a fan would cross the notch.
        let comb =
            xy(&[(0.0, 0.0), (3.0, 0.0), (3.0, 2.0), (2.0, 2.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]);
        let t = triangulate_polygon(&comb);
        let (area, inverted) = area_and_inverted(&comb, &t);
        assert_eq!(inverted, 0);
        assert!((area - 5.0).abs() < 1e-12, "{area}");
    }

    #[test]
    fn non_planar_and_degenerate_faces_still_give_n_minus_2_triangles() {
        // A slightly twisted hexagon, in a tilted plane.
        let tilt = |x: f64, y: f64, z: f64| DVec3::new(x, y * 0.8 + z * 0.6, -y * 0.6 + z * 0.8);
        let hex: Vec<DVec3> = (0..6)
            .map(|i| {
                let a = i as f64 / 6.0 * std::f64::consts::TAU;
                tilt(a.cos(), a.sin(), if i % 2 == 0 { 0.02 } else { -0.02 })
            })
            .collect();
        let t = triangulate_polygon(&hex);
        assert_eq!(t.len(), 4);
        assert_eq!(area_and_inverted(&hex, &t).1, 0);
        // All points on a line: no area, but still four triangles, none referring outside.
        let line: Vec<DVec3> = (0..6).map(|i| DVec3::new(i as f64, 0.0, 0.0)).collect();
        let t = triangulate_polygon(&line);
        assert_eq!(t.len(), 4);
        assert!(t.iter().flatten().all(|&k| k < 6));
        // A bow tie (self-intersecting) falls back without panicking.
        let bow = xy(&[(0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)]);
        assert_eq!(triangulate_polygon(&bow).len(), 2);
    }

    #[test]
    fn faces_map_back_to_the_mesh_indices() {
        let positions: Vec<Vec3> = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0), (5.0, 5.0)]
            .iter()
            .map(|&(x, y)| Vec3::new(x, y, 0.0))
            .collect();
        // A triangle, then the L-shape, with indices offset in the mesh.
        let indices = [6, 0, 1, 0, 1, 2, 3, 4, 5];
        let tris = triangulate_faces(&positions, &indices, &[3, 6]);
        assert_eq!(tris.len(), 3 * (1 + 4));
        assert_eq!(&tris[..3], &[6, 0, 1]);
        assert!(tris[3..].iter().all(|&i| i <= 5));
        assert_eq!(triangulate_faces(&positions, &indices[..3], &[]), vec![6, 0, 1]);
    }
}

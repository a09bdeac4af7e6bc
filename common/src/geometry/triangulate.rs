//! Exact triangulation of planar, possibly concave polygons by ear clipping in the polygon's
//! dominant plane. The triangles use only the polygon's own vertices and keep its winding, so
//! they cover exactly the polygon (a triangle fan would be wrong for the gears' 144-gons).

use crate::vec3::V3;

/// Newell's normal of a polygon (not normalised; zero for a degenerate polygon).
pub fn newell_normal(vs: &[V3<f64>]) -> V3<f64> {
    let mut n = V3::zero();
    for i in 0..vs.len() {
        let a = vs[i];
        let b = vs[(i + 1) % vs.len()];
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    n
}

fn cross2(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// True when `p` lies inside or on the triangle `(a, b, c)` (counter-clockwise).
fn in_triangle(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    cross2(a, b, p) >= 0.0 && cross2(b, c, p) >= 0.0 && cross2(c, a, p) >= 0.0
}

/// Triangulates a polygon given counter-clockwise around its normal. Returns index triples into
/// `vs` that keep the polygon's winding. A polygon that is not simple (self-intersecting) still
/// gets a triangulation of its vertices, but not an exact one.
pub fn triangulate(vs: &[V3<f64>]) -> Vec<[u32; 3]> {
    let n = vs.len();
    if n < 3 {
        return Vec::new();
    }
    if n == 3 {
        return vec![[0, 1, 2]];
    }
    let normal = newell_normal(vs);
    let axis = normal.max_abs_axis();
    let (u, v) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    // Project so the polygon is counter-clockwise in 2D.
    let flip = normal.get(axis) < 0.0;
    let pts: Vec<[f64; 2]> = vs
        .iter()
        .map(|p| {
            if flip {
                [p.get(v), p.get(u)]
            } else {
                [p.get(u), p.get(v)]
            }
        })
        .collect();
    let mut idx: Vec<u32> = (0..n as u32).collect();
    let mut out = Vec::with_capacity(n - 2);
    while idx.len() > 3 {
        let m = idx.len();
        let mut chosen = None;
        let mut fallback = None;
        for i in 0..m {
            let (ip, ic, inx) = (idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]);
            let (a, b, c) = (pts[ip as usize], pts[ic as usize], pts[inx as usize]);
            let turn = cross2(a, b, c);
            if turn < 0.0 {
                continue; // reflex
            }
            if turn == 0.0 {
                fallback.get_or_insert(i);
                continue;
            }
            let blocked = idx.iter().any(|&j| {
                let p = pts[j as usize];
                j != ip
                    && j != ic
                    && j != inx
                    && p != a
                    && p != b
                    && p != c
                    && in_triangle(p, a, b, c)
            });
            if !blocked {
                chosen = Some(i);
                break;
            }
        }
        let i = chosen.or(fallback).unwrap_or(0);
        let m = idx.len();
        out.push([idx[(i + m - 1) % m], idx[i], idx[(i + 1) % m]]);
        idx.remove(i);
    }
    out.push([idx[0], idx[1], idx[2]]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area2(vs: &[V3<f64>], t: [u32; 3]) -> f64 {
        let (a, b, c) = (vs[t[0] as usize], vs[t[1] as usize], vs[t[2] as usize]);
        (b - a).cross(c - a).z
    }

    #[test]
    fn concave_polygon_area_is_preserved_and_winding_kept() {
        // An L shape (concave), counter-clockwise seen from +z.
        let vs: Vec<V3<f64>> = [[0., 0.], [2., 0.], [2., 1.], [1., 1.], [1., 2.], [0., 2.]]
            .iter()
            .map(|p| V3::new(p[0], p[1], 0.0))
            .collect();
        let tris = triangulate(&vs);
        assert_eq!(tris.len(), 4);
        let total: f64 = tris.iter().map(|&t| area2(&vs, t)).sum();
        assert!((total - 6.0).abs() < 1e-12, "2·area = {total}");
        assert!(tris.iter().all(|&t| area2(&vs, t) >= 0.0));
    }

    #[test]
    fn star_with_many_reflex_vertices() {
        let n = 72;
        let vs: Vec<V3<f64>> = (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                let r = if i % 2 == 0 { 1.0 } else { 0.8 };
                V3::new(r * a.cos(), r * a.sin(), 3.0)
            })
            .collect();
        let tris = triangulate(&vs);
        let total: f64 = tris.iter().map(|&t| area2(&vs, t)).sum();
        let exact: f64 = (0..n)
            .map(|i| {
                let (a, b) = (vs[i], vs[(i + 1) % n]);
                a.x * b.y - b.x * a.y
            })
            .sum();
        assert!((total - exact).abs() < 1e-9);
    }
}

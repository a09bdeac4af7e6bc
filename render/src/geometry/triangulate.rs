//! Exact triangulation of planar, possibly concave polygons by ear clipping in the polygon's
//! dominant plane. The triangles use only the polygon's own vertices and keep its winding, so
//! they cover exactly the polygon (a triangle fan would be wrong for the gears' 144-gons). The
//! ear with the shortest new diagonal goes first: a convex run is peeled every other vertex, so
//! triangles stay compact instead of fanning into slivers whose boxes all overlap — on gears-4
//! that halves the BVH's primitive tests per ray.

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
    // The polygon as a doubly linked ring; `ear[i]` caches vertex i's ear quality (the squared
    // length of the diagonal clipping it would cut; smaller is better) or None. Clipping only
    // changes its two neighbours' triangles, and removing a vertex can only unblock others, so
    // a cached ear stays an ear; a cached "not an ear" may go stale, which the full rescan below
    // catches when no cached ear is left.
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut alive = vec![true; n];
    let mut head = 0usize;
    let mut left = n;
    let ear_of = |i: usize, prev: &[usize], next: &[usize], alive: &[bool]| -> Option<f64> {
        let (ip, inx) = (prev[i], next[i]);
        let (a, b, c) = (pts[ip], pts[i], pts[inx]);
        if cross2(a, b, c) <= 0.0 {
            return None; // reflex or collinear
        }
        let blocked = (0..n).any(|j| {
            let p = pts[j];
            alive[j]
                && j != ip
                && j != i
                && j != inx
                && p != a
                && p != b
                && p != c
                && in_triangle(p, a, b, c)
        });
        (!blocked).then(|| {
            let (dx, dy) = (c[0] - a[0], c[1] - a[1]);
            dx * dx + dy * dy
        })
    };
    let mut ear: Vec<Option<f64>> = (0..n).map(|i| ear_of(i, &prev, &next, &alive)).collect();
    let mut out = Vec::with_capacity(n - 2);
    while left > 3 {
        // The best cached ear, first in ring order from `head` on ties.
        let best = |ear: &[Option<f64>]| {
            let mut best: Option<(f64, usize)> = None;
            let mut i = head;
            for _ in 0..left {
                if let Some(q) = ear[i] {
                    if best.is_none_or(|(bq, _)| q < bq) {
                        best = Some((q, i));
                    }
                }
                i = next[i];
            }
            best.map(|(_, i)| i)
        };
        let chosen = best(&ear).or_else(|| {
            let mut i = head;
            for _ in 0..left {
                ear[i] = ear_of(i, &prev, &next, &alive);
                i = next[i];
            }
            best(&ear)
        });
        // No ear at all (a polygon that is not simple): a collinear vertex, else the head.
        let i = chosen.unwrap_or_else(|| {
            let mut i = head;
            for _ in 0..left {
                if cross2(pts[prev[i]], pts[i], pts[next[i]]) == 0.0 {
                    return i;
                }
                i = next[i];
            }
            head
        });
        let (ip, inx) = (prev[i], next[i]);
        out.push([ip as u32, i as u32, inx as u32]);
        alive[i] = false;
        ear[i] = None;
        next[ip] = inx;
        prev[inx] = ip;
        left -= 1;
        if head == i {
            head = inx;
        }
        ear[ip] = ear_of(ip, &prev, &next, &alive);
        ear[inx] = ear_of(inx, &prev, &next, &alive);
    }
    out.push([prev[head] as u32, head as u32, next[head] as u32]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` vertices counter-clockwise around the z axis at height `z`, at equal angles, vertex
    /// `i` at distance `radius(i)` from the axis.
    fn around_z(n: usize, radius: impl Fn(usize) -> f64, z: f64) -> Vec<V3<f64>> {
        (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                V3::new(radius(i) * a.cos(), radius(i) * a.sin(), z)
            })
            .collect()
    }

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
        let vs = around_z(n, |i| if i % 2 == 0 { 1.0 } else { 0.8 }, 3.0);
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

    /// A convex 144-gon (a gear's outline is near that) is peeled, not fanned: every vertex ends
    /// up in O(log n) triangles (a fan puts one vertex in all 142) and no triangle is a sliver
    /// spanning the polygon from one vertex.
    #[test]
    fn convex_polygon_is_peeled_not_fanned() {
        let n = 144;
        let vs = around_z(n, |_| 1.0, 0.0);
        let tris = triangulate(&vs);
        assert_eq!(tris.len(), n - 2);
        let mut uses = vec![0usize; n];
        for t in &tris {
            assert!(area2(&vs, *t) > 0.0);
            for &i in t {
                uses[i as usize] += 1;
            }
        }
        let most = uses.iter().copied().max().unwrap_or(0);
        assert!(most <= 2 * 8 + 2, "a vertex is in {most} triangles");
        let total: f64 = tris.iter().map(|&t| area2(&vs, t)).sum();
        let exact = n as f64 * (std::f64::consts::TAU / n as f64).sin();
        assert!((total - exact).abs() < 1e-9);
    }
}

//! The BVH build over owned bounds (`Bvh::build_owned`, used by `parrt render`) frees as it
//! goes (the bounds while the build records are made, each large subtree's records once it is
//! built, the binary nodes while they are collapsed) and must make exactly the tree the build
//! over borrowed bounds makes. The peak memory it saves is measured in BENCHMARKS.md (peak RSS
//! of `parrt render --scene mount:10`).

use parrt_render::accel::Bvh;
use parrt_render::geometry::Aabb;

/// The boxes of a height field's triangles, two per cell of a `side` × `side` grid, in the
/// order a generator writes them.
fn terrain(side: usize) -> Vec<Aabb> {
    let h = |i: usize, j: usize| ((i * 7919 + j * 104_729) % 1000) as f32 * 1e-4;
    let mut out = Vec::with_capacity(2 * side * side);
    for j in 0..side {
        for i in 0..side {
            let (x, y) = (i as f32, j as f32);
            let zs = [h(i, j), h(i + 1, j), h(i + 1, j + 1), h(i, j + 1)];
            for tri in [[0, 1, 2], [2, 3, 0]] {
                let z = tri.map(|k| zs[k]);
                out.push(Aabb {
                    min: [x, y, z[0].min(z[1]).min(z[2])],
                    max: [x + 1.0, y + 1.0, z[0].max(z[1]).max(z[2])],
                });
            }
        }
    }
    out
}

#[test]
fn the_owned_build_makes_the_same_tree() {
    // 80,000 and 8,000 primitives: several levels of subtrees owning their records and many
    // 4096-node steps of the collapse's freeing; 50 primitives: neither.
    for side in [200, 63, 5] {
        let bounds = terrain(side);
        let reference = Bvh::build(&bounds);
        let owned = Bvh::build_owned(bounds.clone());
        assert_eq!(owned.nodes, reference.nodes, "side {side}");
        assert_eq!(owned.order, reference.order, "side {side}");
        let mut seen = owned.order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..bounds.len() as u32).collect::<Vec<_>>());
    }
}

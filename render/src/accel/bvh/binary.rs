//! A binary hierarchy as builders produce it: 32-byte nodes depth-first (a left child follows
//! its parent) and the primitive order its leaves index into. The traversal structure is made
//! from it ([`super::Bvh::from_binary`]); its SAH cost is the quality figure `--stats` reports.

use super::build::TRAVERSAL_COST;
use super::node::BvhNode;
use crate::geometry::Aabb;

/// A built binary hierarchy.
#[derive(Clone, Debug, Default)]
pub struct BinaryBvh {
    /// Nodes, depth-first; node 0 is the root; a left child follows its parent.
    pub nodes: Vec<BvhNode>,
    /// Primitive indices in leaf order.
    pub order: Vec<u32>,
    /// Deepest leaf.
    pub max_depth: u32,
}

impl BinaryBvh {
    /// Bounds of the whole tree (empty when there is no node).
    pub fn world(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |r| Aabb {
            min: r.min,
            max: r.max,
        })
    }

    /// SAH cost relative to one primitive test: Σ area(node)/area(root) × (traversal cost for
    /// an interior node, primitive count for a leaf).
    pub fn sah_cost(&self) -> f64 {
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        let area = |n: &BvhNode| {
            Aabb {
                min: n.min,
                max: n.max,
            }
            .half_area() as f64
        };
        let root_area = area(root);
        if root_area <= 0.0 {
            return self.order.len() as f64;
        }
        self.nodes
            .iter()
            .map(|n| {
                let a = area(n) / root_area;
                if n.is_leaf() {
                    a * n.count as f64
                } else {
                    a * TRAVERSAL_COST as f64
                }
            })
            .sum()
    }
}

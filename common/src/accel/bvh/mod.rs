//! The bounding volume hierarchy: built with binned SAH ([`build`]) into a binary tree
//! ([`binary`]) of 32-byte nodes ([`node`]), traversed nearer child first with a fixed stack
//! ([`traverse`]).

pub mod binary;
pub mod build;
pub mod goldsmith;
pub mod node;
pub mod traverse;

pub use binary::BinaryBvh;
pub use node::BvhNode;

use crate::accel::{margin, AccelStats};
use crate::geometry::Aabb;

/// A built BVH: nodes and the primitive order its leaves index into.
#[derive(Debug)]
pub struct Bvh {
    /// Nodes, depth-first; node 0 is the root; a left child follows its parent.
    pub nodes: Vec<BvhNode>,
    /// Primitive indices in leaf order.
    pub order: Vec<u32>,
    /// SAH cost of the tree.
    pub sah_cost: f64,
    /// Deepest leaf.
    pub max_depth: u32,
    /// The scene's [`crate::accel::margin`]: a node is pruned only when it starts more than this
    /// (in distance) beyond the best hit, so a rounded entry distance never skips the nearest hit.
    pub margin: f64,
}

impl Bvh {
    /// Builds the binned-SAH hierarchy over primitive bounds (indexed by primitive).
    pub fn build(bounds: &[Aabb]) -> Bvh {
        Bvh::from_binary(build::build_binary(bounds))
    }

    /// Builds the Goldsmith–Salmon hierarchy ([`goldsmith`]), the comparator for the SAH build.
    pub fn build_goldsmith_salmon(bounds: &[Aabb]) -> Bvh {
        Bvh::from_binary(goldsmith::build_goldsmith_salmon(bounds))
    }

    /// The traversal structure of a built binary hierarchy.
    pub fn from_binary(bin: BinaryBvh) -> Bvh {
        let world = bin.world();
        Bvh {
            margin: margin(&world),
            sah_cost: bin.sah_cost(),
            max_depth: bin.max_depth,
            nodes: bin.nodes,
            order: bin.order,
        }
    }

    /// Build statistics.
    pub fn stats(&self) -> AccelStats {
        AccelStats {
            kind: "bvh".into(),
            nodes: self.nodes.len() as u64,
            leaves: self.nodes.iter().filter(|n| n.is_leaf()).count() as u64,
            references: self.order.len() as u64,
            sah_cost: self.sah_cost,
            max_depth: self.max_depth,
            bytes: (self.nodes.len() * std::mem::size_of::<BvhNode>() + self.order.len() * 4)
                as u64,
        }
    }
}

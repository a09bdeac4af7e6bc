//! The bounding volume hierarchy: built with binned SAH ([`build`]) into a binary tree
//! ([`binary`]) of 32-byte nodes ([`node`]), collapsed into 8-wide nodes ([`wide`]) and
//! traversed nearest child first with a fixed stack ([`traverse`]), one ray at a time or in
//! packets of coherent rays ([`packet`]).

pub mod binary;
pub mod build;
pub mod goldsmith;
mod least_surface;
pub mod node;
pub mod packet;
pub mod traverse;
pub mod wide;

pub use binary::BinaryBvh;
pub use node::BvhNode;
pub use wide::WideNode;

use crate::accel::{margin, AccelStats};
use crate::geometry::Aabb;

/// A built BVH: 8-wide nodes and the primitive order its leaves index into.
#[derive(Debug)]
pub struct Bvh {
    /// Wide nodes; node 0 is the root (none for an empty scene).
    pub nodes: Vec<WideNode>,
    /// Primitive indices in leaf order.
    pub order: Vec<u32>,
    /// SAH cost of the binary tree the nodes were collapsed from.
    pub sah_cost: f64,
    /// Deepest leaf of the binary tree.
    pub max_depth: u32,
    /// Leaves.
    pub leaves: u64,
    /// The scene's [`crate::accel::margin`]: a node is pruned only when it starts more than this
    /// (in distance) beyond the best hit, so a rounded entry distance never skips the nearest hit.
    pub margin: f64,
}

impl Bvh {
    /// Builds the binned-SAH hierarchy over primitive bounds (indexed by primitive).
    pub fn build(bounds: &[Aabb]) -> Bvh {
        Bvh::from_binary(build::build_binary(bounds))
    }

    /// Like [`Bvh::build`], but frees the bounds early (a lower peak, the same tree).
    pub fn build_owned(bounds: Vec<Aabb>) -> Bvh {
        Bvh::from_binary(build::build_binary_owned(bounds))
    }

    /// Builds the Goldsmith–Salmon hierarchy ([`goldsmith`]), the comparator for the SAH build.
    pub fn build_goldsmith_salmon(bounds: &[Aabb]) -> Bvh {
        Bvh::from_binary(goldsmith::build_goldsmith_salmon(bounds))
    }

    /// The traversal structure of a built binary hierarchy.
    ///
    /// # Panics
    /// When the tree holds more than 2²⁹ primitive references; scenes are limited far below
    /// that (`--max-primitives`).
    pub fn from_binary(bin: BinaryBvh) -> Bvh {
        let margin = margin(&bin.world());
        let sah_cost = bin.sah_cost();
        let leaves = bin.nodes.iter().filter(|n| n.is_leaf()).count() as u64;
        let nodes = match wide::collapse(bin.nodes, bin.order.len()) {
            Ok(nodes) => nodes,
            Err(wide::TooManyReferences(n)) => {
                panic!("{n} primitive references exceed the BVH's 2^29 limit")
            }
        };
        Bvh {
            margin,
            sah_cost,
            max_depth: bin.max_depth,
            leaves,
            nodes,
            order: bin.order,
        }
    }

    /// Build statistics.
    pub fn stats(&self) -> AccelStats {
        AccelStats {
            kind: "bvh".into(),
            nodes: self.nodes.len() as u64,
            leaves: self.leaves,
            references: self.order.len() as u64,
            sah_cost: self.sah_cost,
            max_depth: self.max_depth,
            bytes: (self.nodes.len() * std::mem::size_of::<WideNode>() + self.order.len() * 4)
                as u64,
            ..AccelStats::default()
        }
    }
}

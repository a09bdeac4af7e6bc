//! The bounding volume hierarchy: built with binned SAH ([`build`]), stored as a flat depth-first
//! array of 32-byte nodes ([`node`]), traversed nearer child first with a fixed stack
//! ([`traverse`]).

pub mod build;
pub mod node;
pub mod traverse;

pub use node::BvhNode;

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

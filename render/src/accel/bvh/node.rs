//! The BVH's traversal node: 32 bytes (asserted at compile time), so two fit a cache line.

/// A node: bounds, then either the first primitive and a count (leaf) or the second child's index
/// and the split axis (interior; the first child is the next node).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct BvhNode {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Leaf: first index into the primitive order. Interior: index of the second child.
    pub offset: u32,
    /// Maximum corner.
    pub max: [f32; 3],
    /// Primitives in the leaf; 0 for an interior node.
    pub count: u16,
    /// Split axis of an interior node (0, 1, 2).
    pub axis: u16,
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);

impl BvhNode {
    /// True for a leaf.
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

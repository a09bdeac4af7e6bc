//! The coordinates the kernel-agreement property tests draw (test builds only): mostly small
//! values, with exact zeros, ±1, tiny and huge values often enough that axis-parallel rays,
//! rays through vertices and edges, and far geometry come up in every run.

use proptest::prelude::*;

/// One coordinate.
pub(crate) fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -4.0f32..4.0,
        1 => Just(0.0f32),
        1 => Just(1.0f32),
        1 => Just(-1.0f32),
        1 => -1.0e-3f32..1.0e-3,
        1 => -3.0e4f32..3.0e4,
    ]
}

/// A point or direction: three coordinates.
pub(crate) fn point() -> impl Strategy<Value = [f32; 3]> {
    proptest::array::uniform3(coord())
}

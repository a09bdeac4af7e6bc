//! Accelerators and traversal, one test binary: the BVH (borrowed and owned builds), the grid
//! and brute force agree on every ray; SIMD and scalar leaf tests agree; packets of rays get
//! exactly the answers their rays get alone.

use parrt_test_support as support;

mod agreement;
mod bvh_owned;
mod grid_rays;
mod lanes;
mod leaf_simd;
mod packet_leaf;
mod packets;

//! Render settings: everything besides the scene that decides an image's pixels. Sent to workers
//! with each job, so the same settings give the same bits on every node.

use serde::{Deserialize, Serialize};

/// Scalar precision of the geometric computations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum Precision {
    /// Single precision: the fast path.
    #[default]
    F32,
    /// Double precision: the reference path.
    F64,
    /// Whichever of the two the scene needs ([`crate::precision::resolve`]): resolved once from
    /// the description before a render, so a worker is sent `F32` or `F64`. Last, so the wire
    /// encoding of the others stays the same.
    Auto,
}

/// Which acceleration structure answers ray queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum AccelKind {
    /// Bounding volume hierarchy (binned SAH).
    #[default]
    Bvh,
    /// Uniform voxel grid with 3D-DDA.
    Grid,
    /// Every primitive for every ray: the oracle.
    Brute,
    /// Bounding volume hierarchy built by Goldsmith–Salmon incremental insertion: the classic
    /// hierarchy the SAH build is compared against. Last, so the wire encoding of the others
    /// stays the same.
    BvhGoldsmithSalmon,
}

/// The default adaptive cut-off: a path whose weight product falls below this is not continued.
pub const DEFAULT_CUTOFF: f64 = 0.001;
/// The default recursion limit (the eye ray is depth 1).
pub const DEFAULT_MAX_DEPTH: u32 = 5;
/// The default uniform-grid density (cells per primitive, before the cube root): 27 gives
/// pbrt-v2's 3·∛N cells along the longest axis. Measured on the SPD default scenes at densities
/// 3, 8, 27 and 100 (`bench/accel_table.sh`, `bench/results/`): 27 has the smallest geometric
/// mean of grid/BVH trace time on the scenes without a huge floor; on balls and tree, whose
/// floors squeeze everything into a few cells, only higher densities help (and not enough).
pub const DEFAULT_GRID_DENSITY: f64 = 27.0;
/// The largest uniform-grid density a render may ask for: cells per primitive before the cube
/// root, so with the grid's absolute cap ([`crate::accel::grid::build::MAX_CELLS`]) it bounds
/// the grid's memory for small and large scenes alike. Densities past ~100 never helped.
pub const MAX_GRID_DENSITY: f64 = 1e4;

/// All settings that decide pixel values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Maximum ray depth; the eye ray is depth 1.
    pub max_depth: u32,
    /// Adaptive cut-off on the product of reflect/transmit weights; 0 disables it.
    pub cutoff: f64,
    /// Samples per pixel (1 = one ray through the pixel centre).
    pub spp: u32,
    /// Haines' SPD testing procedure (corner rays, one-sided opaque primitives, no cut-off).
    pub spd_standard: bool,
    /// Make every primitive two-sided in the SPD procedure (the teapot needs it).
    pub two_sided: bool,
    /// Geometric precision.
    pub precision: Precision,
    /// Acceleration structure.
    pub accel: AccelKind,
    /// Uniform-grid density.
    pub grid_density: f64,
}

impl RenderSettings {
    /// Default settings for an image of the given size.
    pub fn new(width: u32, height: u32) -> Self {
        RenderSettings {
            width,
            height,
            max_depth: DEFAULT_MAX_DEPTH,
            cutoff: DEFAULT_CUTOFF,
            spp: 1,
            spd_standard: false,
            two_sided: false,
            precision: Precision::F32,
            accel: AccelKind::Bvh,
            grid_density: DEFAULT_GRID_DENSITY,
        }
    }
}

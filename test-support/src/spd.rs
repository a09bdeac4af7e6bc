//! SPD scene files and the three-accelerator oracle: load the SPD scenes (see
//! [`crate::spd_dir`]), build BVH, grid and brute force over one scene, and check that a ray gets
//! the same answer from all three. Test support only; never used by the renderer.

use crate::spd_dir;
use parrt_render::accel::Accel;
use parrt_render::description::SceneDescription;
use parrt_render::geometry::{PreparedRay, PrimHit, Ray};
use parrt_render::packet::scene_leaf::SceneLeaf;
use parrt_render::real::Real;
use parrt_render::scene::Scene;
use parrt_render::settings::AccelKind;
use parrt_render::stats::RayStats;

/// The small SPD files (a few hundred primitives each) of the scene table.
pub const SMALL_SCENES: &[&str] = &[
    "balls-3",
    "gears-1",
    "gears-2",
    "mount-4",
    "rings-2",
    "teapot-2",
    "tetra-4",
    "tree-6",
    "lattice-4",
    "shells-1",
    "jacks-3",
    "sombrero-1",
    "sample-1",
    "nurbtst-1",
];

/// Parses SPD scene `name` (without `.nff`); panics with the reason when it cannot.
pub fn load(name: &str) -> SceneDescription {
    let path = spd_dir().join(format!("{name}.nff"));
    parrt_render::nff::parse_file(&path, &parrt_render::nff::Limits::default())
        .unwrap_or_else(|e| panic!("{}: {e} (set PARRT_SPD_DIR)", path.display()))
}

/// One scene with all three accelerators built over the same primitive bounds.
pub struct Trio<R> {
    /// The render-ready scene.
    pub scene: Scene<R>,
    /// Bounding volume hierarchy.
    pub bvh: Accel,
    /// Uniform grid.
    pub grid: Accel,
    /// Linear scan, the oracle.
    pub brute: Accel,
}

/// Per-accelerator test counts summed over the rays a [`Trio`] checked.
#[derive(Clone, Copy, Debug, Default)]
pub struct TrioStats {
    /// Rays checked.
    pub rays: u64,
    /// Rays with a closest hit.
    pub hits: u64,
    /// Rays found occluded.
    pub occluded: u64,
    /// BVH statistics.
    pub bvh: RayStats,
    /// Grid statistics.
    pub grid: RayStats,
    /// Brute-force statistics.
    pub brute: RayStats,
}

/// The parts of a closest hit that must agree bit for bit.
pub fn key<R: Real>(h: &Option<PrimHit<R>>) -> Option<(u32, u64, u64, u64)> {
    h.map(|h| {
        (
            h.prim,
            h.t.to_f64().to_bits(),
            h.u.to_f64().to_bits(),
            h.v.to_f64().to_bits(),
        )
    })
}

impl<R: Real> Trio<R> {
    /// Builds the scene of `desc` and the three accelerators (grid at `density`).
    pub fn new(desc: &SceneDescription, density: f64) -> Self {
        let scene = Scene::<R>::build(desc).unwrap_or_else(|e| panic!("scene: {e}"));
        Self::from_scene(scene, density)
    }

    /// Builds the three accelerators over `scene`.
    pub fn from_scene(scene: Scene<R>, density: f64) -> Self {
        let bounds = scene.all_bounds();
        Trio {
            bvh: Accel::build(AccelKind::Bvh, &bounds, density),
            grid: Accel::build(AccelKind::Grid, &bounds, density),
            brute: Accel::build(AccelKind::Brute, &bounds, density),
            scene,
        }
    }

    /// Checks one ray: the same closest hit (primitive, `t`, `u`, `v` bit for bit) and the same
    /// occlusion answer from all three. `Err` describes the disagreement.
    pub fn check(&self, ray: &Ray<R>, st: &mut TrioStats) -> Result<(), String> {
        self.check_with(ray, st, true)
    }

    /// [`Trio::check`], comparing the BVH too only when `with_bvh`.
    pub fn check_with(
        &self,
        ray: &Ray<R>,
        st: &mut TrioStats,
        with_bvh: bool,
    ) -> Result<(), String> {
        let pr = PreparedRay::new(*ray);
        let test = |i: u32, t: R| self.scene.intersect_prim(i, &pr, t);
        let want = self.brute.intersect(&pr, &mut st.brute, test);
        // The BVH with the leaf test the renderer uses (triangle leaves four at a time).
        let bvh = self
            .bvh
            .intersect(&pr, &mut st.bvh, SceneLeaf::new(&self.scene).ray(&pr));
        let grid = self.grid.intersect(&pr, &mut st.grid, test);
        let occ_want = self.brute.occluded(&pr, &mut st.brute, test);
        let occ_bvh = self
            .bvh
            .occluded(&pr, &mut st.bvh, SceneLeaf::new(&self.scene).ray(&pr));
        let occ_grid = self.grid.occluded(&pr, &mut st.grid, test);
        st.rays += 1;
        st.hits += want.is_some() as u64;
        st.occluded += occ_want as u64;
        let mut err = String::new();
        if with_bvh && key(&bvh) != key(&want) {
            err += &format!("bvh closest hit {bvh:?} != brute {want:?}; ");
        }
        if key(&grid) != key(&want) {
            err += &format!("grid closest hit {grid:?} != brute {want:?}; ");
        }
        if (with_bvh && occ_bvh != occ_want) || occ_grid != occ_want {
            err += &format!("occluded: brute {occ_want}, bvh {occ_bvh}, grid {occ_grid}; ");
        }
        if occ_want != want.is_some() {
            err += &format!("brute disagrees with itself: hit {want:?}, occluded {occ_want}; ");
        }
        if err.is_empty() {
            Ok(())
        } else {
            Err(format!("{err}ray {ray:?}"))
        }
    }

    /// Checks every ray and panics with the first few disagreements (and their count).
    pub fn check_all(&self, what: &str, rays: &[Ray<R>]) -> TrioStats {
        self.check_all_with(what, rays, true)
    }

    /// [`Trio::check_all`] for the grid against brute force only.
    pub fn check_grid(&self, what: &str, rays: &[Ray<R>]) -> TrioStats {
        self.check_all_with(what, rays, false)
    }

    fn check_all_with(&self, what: &str, rays: &[Ray<R>], with_bvh: bool) -> TrioStats {
        let mut st = TrioStats::default();
        let mut bad = Vec::new();
        for r in rays {
            if let Err(e) = self.check_with(r, &mut st, with_bvh) {
                bad.push(e);
            }
        }
        assert!(
            bad.is_empty(),
            "{what}: {} of {} rays disagree; first: {}",
            bad.len(),
            rays.len(),
            bad.iter().take(3).cloned().collect::<Vec<_>>().join("\n")
        );
        st
    }
}

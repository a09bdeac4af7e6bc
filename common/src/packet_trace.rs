//! Eye rays in packets: a block of up to [`PACKET`] eye rays finds its hits together, and the
//! shadow rays of those hits go to each light together too
//! ([`crate::accel::bvh::packet`]); reflection and refraction rays then go on one by one. Every
//! ray gets the answer it gets alone, and shading is the same code, so the colours are the same
//! bits as tracing each eye ray on its own.

use crate::accel::bvh::packet::PACKET;
use crate::geometry::{PreparedRay, PrimHit, Ray};
use crate::real::Real;
use crate::shade::{Integrator, Lit};
use crate::stats::RayStats;
use crate::vec3::V3;

impl<R: Real> Integrator<R> {
    /// Closest hits of up to [`PACKET`] rays, into `out`.
    pub fn intersect_packet(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [Option<PrimHit<R>>],
        stats: &mut RayStats,
    ) {
        self.accel.intersect_packet(rays, out, stats, |pr, p, t| {
            self.scene.intersect_prim(p, pr, t)
        });
    }

    /// Occlusion of up to [`PACKET`] rays, into `out`.
    pub fn occluded_packet(&self, rays: &[PreparedRay<R>], out: &mut [bool], stats: &mut RayStats) {
        self.accel.occluded_packet(rays, out, stats, |pr, p, t| {
            self.scene.intersect_prim(p, pr, t)
        });
    }

    /// Radiance along up to [`PACKET`] eye rays, into `out`: the same colours as
    /// [`Integrator::trace`] gives each (depth 1, weight 1). `blocked` is scratch space (one
    /// mask of rays per light), kept by the caller so nothing is allocated per packet.
    pub fn trace_eye_packet(
        &self,
        rays: &[Ray<R>],
        out: &mut [V3<R>],
        blocked: &mut Vec<u16>,
        stats: &mut RayStats,
    ) {
        let n = rays.len();
        assert!(n <= PACKET && out.len() >= n);
        let Some(&first) = rays.first() else {
            return;
        };
        stats.eye_rays += n as u64;
        let mut prs = [PreparedRay::new(first); PACKET];
        for (pr, r) in prs.iter_mut().zip(rays) {
            *pr = PreparedRay::new(*r);
        }
        let mut hits = [None; PACKET];
        self.intersect_packet(&prs[..n], &mut hits[..n], stats);
        let mut lits: [Option<Lit<R>>; PACKET] = [None; PACKET];
        for i in 0..n {
            if let Some(h) = &hits[i] {
                stats.eye_hits += 1;
                lits[i] = Some(self.lit(&rays[i], h));
            }
        }
        // Shadow rays light by light: bit i of blocked[light] says ray i's is blocked.
        blocked.clear();
        blocked.resize(self.scene.lights.len(), 0);
        for (li, mask) in blocked.iter_mut().enumerate() {
            let mut shadow = [prs[0]; PACKET];
            let mut owner = [0usize; PACKET];
            let mut k = 0;
            for (i, lit) in lits[..n].iter().enumerate() {
                if let Some((r, _, _)) = lit.as_ref().and_then(|l| self.shadow_ray(l, li)) {
                    shadow[k] = PreparedRay::new(r);
                    owner[k] = i;
                    k += 1;
                }
            }
            let mut occ = [false; PACKET];
            self.occluded_packet(&shadow[..k], &mut occ[..k], stats);
            for j in 0..k {
                if occ[j] {
                    *mask |= 1 << owner[j];
                }
            }
        }
        for i in 0..n {
            out[i] = match &lits[i] {
                None => self.scene.background,
                Some(lit) => self.shade(&rays[i], lit, 1, R::ONE, stats, |li, _, _| {
                    blocked[li] & (1 << i) != 0
                }),
            };
        }
    }
}

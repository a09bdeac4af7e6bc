//! Rays in packets: a block of up to [`PACKET`] eye rays finds its hits together, and the
//! shadow rays of those hits go to each light together too
//! ([`crate::accel::bvh::packet`]); the hits' reflection rays then go on together as one packet
//! and their refraction rays as another, level by level (mirror reflections off a flat floor
//! stay as coherent as the eye rays; incoherent ones are traced one by one inside the packet
//! code). Every ray gets the answer it gets alone, and shading is the same code summed in the
//! same order, so the colours are the same bits as tracing each eye ray on its own.

use crate::accel::bvh::packet::PACKET;
use crate::geometry::{PreparedRay, PrimHit, Ray};
use crate::packet_leaf::PacketLeaf;
use crate::real::Real;
use crate::shade::{Integrator, Lit, RayKind};
use crate::stats::RayStats;
use crate::vec3::V3;

/// Deepest level whose secondary rays still go in packets; deeper ones go one by one, so the
/// recursion's stack (a few kilobytes of packet state per level) stays small at any depth limit.
pub const PACKET_DEPTH: u32 = 8;

/// Widest spread of secondary rays' unit directions (largest difference of a component) that
/// still goes as a packet. `parrt render` CPU time on the SPD scenes, A/B against one-by-one
/// secondary rays, at 0.05, 0.15, 0.3 and no limit: 0.15 gained 5–20 % on mount, gears,
/// teapot, shells and lattice and lost at most 2 % elsewhere; without a limit jacks lost 12 %
/// (reflections off its curved arms share direction signs but fan out). Measured again once a
/// packet's rays tested leaves together (`bench/ab_render.sh`, 0.08, 0.15, 0.25, 0.35, 0.5 and
/// 2): 0.35-0.5 is best; 0.35 against 0.15, 7 runs: shells 0.93, teapot 0.97, gears and mount
/// 0.975, nothing slower; 0.08 costs mount 10 %, no limit costs jacks 12 % and balls 4 %.
pub const SECONDARY_SPREAD: f64 = 0.35;

/// Whether secondary rays point closely enough the same way to be traced as a packet
/// ([`SECONDARY_SPREAD`]).
pub fn directions_close<R: Real>(rays: &[Ray<R>]) -> bool {
    let first = rays[0].d;
    let (mut lo, mut hi) = (first, first);
    for r in &rays[1..] {
        lo = V3::new(lo.x.min(r.d.x), lo.y.min(r.d.y), lo.z.min(r.d.z));
        hi = V3::new(hi.x.max(r.d.x), hi.y.max(r.d.y), hi.z.max(r.d.z));
    }
    let spread = (hi.x - lo.x).max(hi.y - lo.y).max(hi.z - lo.z);
    spread <= R::from_f64(SECONDARY_SPREAD)
}

impl<R: Real> Integrator<R> {
    /// Closest hits of up to [`PACKET`] rays, into `out`.
    pub fn intersect_packet(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [Option<PrimHit<R>>],
        stats: &mut RayStats,
    ) {
        self.accel
            .intersect_packet(rays, out, stats, PacketLeaf::new(&self.scene));
    }

    /// Occlusion of up to [`PACKET`] rays, into `out`.
    pub fn occluded_packet(&self, rays: &[PreparedRay<R>], out: &mut [bool], stats: &mut RayStats) {
        self.accel
            .occluded_packet(rays, out, stats, PacketLeaf::new(&self.scene));
    }

    /// Radiance along up to [`PACKET`] eye rays, into `out`: the same colours as
    /// [`Integrator::trace`] gives each (depth 1, weight 1).
    pub fn trace_eye_packet(&self, rays: &[Ray<R>], out: &mut [V3<R>], stats: &mut RayStats) {
        let weights = [R::ONE; PACKET];
        self.trace_packet(rays, 1, &weights, RayKind::Eye, out, stats);
    }

    /// Radiance along up to [`PACKET`] rays of one kind at `depth`, ray `i` with path weight
    /// `weights[i]`, into `out`: the colours [`Integrator::trace`] gives each. The hits'
    /// reflection rays then go on as one packet, and their refraction rays as another, when
    /// there are two or more and their directions are close ([`SECONDARY_SPREAD`]), down to
    /// [`PACKET_DEPTH`]; otherwise they go one by one.
    #[allow(clippy::too_many_arguments)]
    pub fn trace_packet(
        &self,
        rays: &[Ray<R>],
        depth: u32,
        weights: &[R],
        kind: RayKind,
        out: &mut [V3<R>],
        stats: &mut RayStats,
    ) {
        let n = rays.len();
        assert!(n <= PACKET && out.len() >= n && weights.len() >= n);
        let Some(&first) = rays.first() else {
            return;
        };
        match kind {
            RayKind::Eye => stats.eye_rays += n as u64,
            RayKind::Reflection => stats.reflection_rays += n as u64,
            RayKind::Refraction => stats.refraction_rays += n as u64,
        }
        let mut prs = [PreparedRay::new(first); PACKET];
        for (pr, r) in prs.iter_mut().zip(rays) {
            *pr = PreparedRay::new(*r);
        }
        let mut hits = [None; PACKET];
        self.intersect_packet(&prs[..n], &mut hits[..n], stats);
        let mut lits: [Option<Lit<R>>; PACKET] = [None; PACKET];
        for i in 0..n {
            if let Some(h) = &hits[i] {
                match kind {
                    RayKind::Eye => stats.eye_hits += 1,
                    RayKind::Reflection => stats.reflection_hits += 1,
                    RayKind::Refraction => stats.refraction_hits += 1,
                }
                lits[i] = Some(self.lit(&rays[i], h));
            }
        }
        // Direct light, light by light: each light's shadow rays go as one packet, and each
        // ray's colour gets the terms in direct()'s order (ambient, then the lights in turn).
        for i in 0..n {
            out[i] = match &lits[i] {
                None => self.scene.background,
                Some(lit) => self.ambient(lit),
            };
        }
        // Made once for all the lights: every light's packet overwrites what it uses.
        let mut shadow = [prs[0]; PACKET];
        let mut owner = [0usize; PACKET];
        let mut toward = [(R::ZERO, R::ZERO); PACKET];
        let mut occ = [false; PACKET];
        for li in 0..self.scene.lights.len() {
            let mut k = 0;
            for (i, lit) in lits[..n].iter().enumerate() {
                if let Some((r, n_dot_l_raw, dist)) =
                    lit.as_ref().and_then(|l| self.shadow_ray(l, li))
                {
                    shadow[k] = PreparedRay::new(r);
                    owner[k] = i;
                    toward[k] = (n_dot_l_raw, dist);
                    k += 1;
                }
            }
            self.occluded_packet(&shadow[..k], &mut occ[..k], stats);
            stats.shadow_rays += k as u64;
            for j in 0..k {
                if occ[j] {
                    stats.shadow_hits += 1;
                } else if let Some(lit) = &lits[owner[j]] {
                    let (n_dot_l_raw, dist) = toward[j];
                    out[owner[j]] += self.from_light(&rays[owner[j]], lit, li, n_dot_l_raw, dist);
                }
            }
        }
        if depth >= self.opts.max_depth {
            return;
        }
        let mut spawned = [None; PACKET];
        for i in 0..n {
            if let Some(lit) = &lits[i] {
                spawned[i] = Some(self.spawn(&rays[i], lit, depth, weights[i]));
            }
        }
        // Reflections, then refractions: each colour gets the terms in shade()'s order.
        for refraction in [false, true] {
            let mut next = [first; PACKET];
            let mut next_w = [R::ZERO; PACKET];
            let mut w_of = [R::ZERO; PACKET];
            let mut owner = [0usize; PACKET];
            let mut k = 0;
            for (i, sp) in spawned[..n].iter().enumerate() {
                let ray = sp.and_then(|sp| {
                    if refraction {
                        sp.refraction
                    } else {
                        sp.reflection
                    }
                });
                if let Some((r, w)) = ray {
                    next[k] = r;
                    next_w[k] = weights[i] * w;
                    w_of[k] = w;
                    owner[k] = i;
                    k += 1;
                }
            }
            if k == 0 {
                continue;
            }
            let kind = if refraction {
                RayKind::Refraction
            } else {
                RayKind::Reflection
            };
            let mut colors = [V3::zero(); PACKET];
            if depth < PACKET_DEPTH && k > 1 && directions_close(&next[..k]) {
                self.trace_packet(
                    &next[..k],
                    depth + 1,
                    &next_w[..k],
                    kind,
                    &mut colors[..k],
                    stats,
                );
            } else {
                for j in 0..k {
                    colors[j] = self.trace(&next[j], depth + 1, next_w[j], kind, stats);
                }
            }
            for j in 0..k {
                out[owner[j]] += colors[j] * w_of[j];
            }
        }
    }
}

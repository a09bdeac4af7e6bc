//! Rays in packets: a block of up to [`PACKET`] eye rays finds its hits together, and the
//! shadow rays of those hits go to each light together too
//! ([`crate::accel::bvh::packet`]); the hits' reflection rays then go on together as one packet
//! and their refraction rays as another, level by level (mirror reflections off a flat floor
//! stay as coherent as the eye rays; incoherent ones are traced one by one inside the packet
//! code). Every ray gets the answer it gets alone, and shading is the same code summed in the
//! same order, so the colours are the same bits as tracing each eye ray on its own. In `f32` on
//! the `avx2` and `avx512` tiers the eye packet and its shadow packets live in lanes
//! ([`Integrator::trace_eye_block`]), and on `avx2` so do the shadow packets of the secondary
//! rays ([`Integrator::trace_packet`]).

use std::any::{Any, TypeId};

use crate::accel::bvh::packet::PACKET;
use crate::camera::Camera;
use crate::geometry::packet_prims::ShearedRays;
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::{PreparedRay, PrimHit, Ray};
use crate::packet::buffers::PacketBuffers;
use crate::packet::leaf::{LanesLeaf, PacketLeaf};
use crate::packet::shadow::{shadow_lanes, SurfaceLanes};
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
    /// Closest hits of up to [`PACKET`] rays, into `out`; the rays are put in lanes in
    /// `lanes` if a leaf needs them (a slot the caller's packets share, [`PacketLeaf`]).
    pub fn intersect_packet(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [Option<PrimHit<R>>],
        lanes: &mut Option<ShearedRays>,
        stats: &mut RayStats,
    ) {
        let test = PacketLeaf::new(&self.scene, lanes);
        self.accel.intersect_packet(rays, out, stats, test);
    }

    /// Occlusion of up to [`PACKET`] rays, into `out`; `lanes` as for
    /// [`Integrator::intersect_packet`].
    pub fn occluded_packet(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [bool],
        lanes: &mut Option<ShearedRays>,
        stats: &mut RayStats,
    ) {
        let test = PacketLeaf::new(&self.scene, lanes);
        self.accel.occluded_packet(rays, out, stats, test);
    }

    /// Radiance along up to [`PACKET`] eye rays, into `out`: the same colours as
    /// [`Integrator::trace`] gives each (depth 1, weight 1).
    pub fn trace_eye_packet(&self, rays: &[Ray<R>], out: &mut [V3<R>], stats: &mut RayStats) {
        let weights = [R::ONE; PACKET];
        self.trace_packet(rays, 1, &weights, RayKind::Eye, out, stats);
    }

    /// Radiance along the eye rays through the centres of the pixels `bx..bx + bw` ×
    /// `by..by + bh` (at most [`PACKET`], row by row), into `out`'s first `bw × bh`: the colours
    /// [`Integrator::trace_eye_packet`] gives `camera.ray(x + 0.5, y + 0.5)`. In `f32` on the
    /// `avx2` and `avx512` tiers the rays are made in lanes and the hits and their shadow rays
    /// found in lanes ([`RayPacket`], [`crate::packet::shadow`]), in `buffers` (one set for all
    /// of a tile's packets); the rest (shading, secondary rays) is the same code either way.
    /// The other tiers and `f64` make the rays one by one
    /// (the lanes do not pay there, as measured in bench/results/; on `avx2` they pay once
    /// the shadow rays and the packet's bounds are in eight-lane registers too).
    pub fn trace_eye_block(
        &self,
        camera: &Camera<R>,
        (bx, by, bw, bh): (u32, u32, u32, u32),
        out: &mut [V3<R>; PACKET],
        buffers: &mut PacketBuffers,
        stats: &mut RayStats,
    ) {
        if let (Some(integrator), Some(camera), Some(out), true) = (
            (self as &dyn Any).downcast_ref::<Integrator<f32>>(),
            (camera as &dyn Any).downcast_ref::<Camera<f32>>(),
            (out as &mut dyn Any).downcast_mut::<[V3<f32>; PACKET]>(),
            crate::isa::current().avx(),
        ) {
            return integrator.trace_eye_lanes(camera, (bx, by, bw, bh), out, buffers, stats);
        }
        let mut rays = [camera.ray(R::HALF, R::HALF); PACKET];
        let mut n = 0;
        for y in by..by + bh {
            for x in bx..bx + bw {
                let (sx, sy) = (x as f64 + 0.5, y as f64 + 0.5);
                rays[n] = camera.ray(R::from_f64(sx), R::from_f64(sy));
                n += 1;
            }
        }
        self.trace_eye_packet(&rays[..n], &mut out[..n], stats);
    }

    /// Radiance along up to [`PACKET`] rays of one kind at `depth`, ray `i` with path weight
    /// `weights[i]`, into `out`: the colours [`Integrator::trace`] gives each. The hits'
    /// reflection rays then go on as one packet, and their refraction rays as another, when
    /// there are two or more and their directions are close ([`SECONDARY_SPREAD`]), down to
    /// [`PACKET_DEPTH`]; otherwise they go one by one. In `f32` on the `avx2` tier each light's
    /// shadow rays are made and answered in lanes (as the eye packets' are); the `avx512`
    /// tier's secondary packets keep prepared shadow rays (lanes there were not measured).
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
        count_rays(kind, n, stats);
        let mut prs = [PreparedRay::new(first); PACKET];
        for (pr, r) in prs.iter_mut().zip(rays) {
            *pr = PreparedRay::new(*r);
        }
        let mut hits = [None; PACKET];
        // One slot of lanes for the hits and every light's shadow rays.
        let mut lanes = None;
        self.intersect_packet(&prs[..n], &mut hits[..n], &mut lanes, stats);
        let lits = self.lits(rays, &hits[..n], kind, out, stats);
        if !self.lights_in_lanes(rays, &lits, &mut prs, out, stats) {
            self.lights_one_by_one(rays, &lits, &prs[0], &mut lanes, out, stats);
        }
        self.trace_secondary(rays, &lits, depth, weights, out, stats);
    }

    /// Every light's term for a packet's lit hits (of `rays`), [`Integrator::add_light`] light
    /// by light, each light's shadow rays made and prepared one by one and answered together
    /// (`any` serves as the arrays' filler, `lanes` as [`Integrator::occluded_packet`]'s).
    // Not inlined into `trace_packet`: there, once that function also held the lanes' branch,
    // the compiler stopped inlining `offset_ray_origin` into these shadow rays (`sse2`
    // teapot-6: 1 % more render instructions).
    #[inline(never)]
    fn lights_one_by_one(
        &self,
        rays: &[Ray<R>],
        lits: &[Option<Lit<R>>; PACKET],
        any: &PreparedRay<R>,
        lanes: &mut Option<ShearedRays>,
        out: &mut [V3<R>],
        stats: &mut RayStats,
    ) {
        let n = rays.len();
        // Made once for all the lights: every light's packet overwrites what it uses.
        let mut shadow = [*any; PACKET];
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
            self.occluded_packet(&shadow[..k], &mut occ[..k], lanes, stats);
            self.add_light(rays, lits, li, &occ[..k], &owner, &toward, out, stats);
        }
    }

    /// On the `avx2` tier in `f32`, [`Integrator::lights_lanes`] for a packet's lit hits, with
    /// `buffer` for the rays a leaf takes one by one; `false` (and nothing done) elsewhere.
    fn lights_in_lanes(
        &self,
        rays: &[Ray<R>],
        lits: &[Option<Lit<R>>; PACKET],
        buffer: &mut [PreparedRay<R>; PACKET],
        out: &mut [V3<R>],
        stats: &mut RayStats,
    ) -> bool {
        let tier = crate::isa::current();
        if !tier.avx() || tier.avx512() {
            return false;
        }
        if let (Some(integrator), Some(rays), Some(lits), Some(buffer), Some(out)) = (
            (self as &dyn Any).downcast_ref::<Integrator<f32>>(),
            same_slice::<Ray<R>, Ray<f32>>(rays),
            (lits as &dyn Any).downcast_ref::<[Option<Lit<f32>>; PACKET]>(),
            (buffer as &mut dyn Any).downcast_mut::<[PreparedRay<f32>; PACKET]>(),
            same_slice_mut::<V3<R>, V3<f32>>(out),
        ) {
            let mut shadow = RayPacket::new();
            integrator.lights_lanes(rays, lits, buffer, &mut shadow, out, stats);
            return true;
        }
        false
    }

    /// The lit hits of a packet's rays (counted in `stats` by `kind`), and each ray's colour
    /// started in `out`: the background, or the hit's ambient term (direct()'s first term).
    fn lits(
        &self,
        rays: &[Ray<R>],
        hits: &[Option<PrimHit<R>>],
        kind: RayKind,
        out: &mut [V3<R>],
        stats: &mut RayStats,
    ) -> [Option<Lit<R>>; PACKET] {
        let mut lits: [Option<Lit<R>>; PACKET] = [None; PACKET];
        for (i, h) in hits.iter().enumerate() {
            if let Some(h) = h {
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
        for i in 0..hits.len() {
            out[i] = match &lits[i] {
                None => self.scene.background,
                Some(lit) => self.ambient(lit),
            };
        }
        lits
    }

    /// Light `li`'s terms for the shadow rays whose occlusion is `occ`, ray `j` from the hit of
    /// ray `owner[j]` with `toward[j]` its `n·l` and distance ([`Integrator::shadow_ray`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn add_light(
        &self,
        rays: &[Ray<R>],
        lits: &[Option<Lit<R>>; PACKET],
        li: usize,
        occ: &[bool],
        owner: &[usize; PACKET],
        toward: &[(R, R); PACKET],
        out: &mut [V3<R>],
        stats: &mut RayStats,
    ) {
        stats.shadow_rays += occ.len() as u64;
        for (j, &o) in occ.iter().enumerate() {
            if o {
                stats.shadow_hits += 1;
            } else if let Some(lit) = &lits[owner[j]] {
                let (n_dot_l_raw, dist) = toward[j];
                out[owner[j]] += self.from_light(&rays[owner[j]], lit, li, n_dot_l_raw, dist);
            }
        }
    }

    /// The reflection and refraction rays of a packet's lit hits at `depth`, traced and added
    /// to `out` (in shade()'s order).
    fn trace_secondary(
        &self,
        rays: &[Ray<R>],
        lits: &[Option<Lit<R>>; PACKET],
        depth: u32,
        weights: &[R],
        out: &mut [V3<R>],
        stats: &mut RayStats,
    ) {
        let n = rays.len();
        let first = rays[0];
        if depth >= self.opts.max_depth {
            return;
        }
        let mut spawned = [None; PACKET];
        // Whether any hit reflects, and whether any refracts (most packets of most scenes do
        // neither: then nothing below is set up).
        let mut kinds = [false; 2];
        for i in 0..n {
            if let Some(lit) = &lits[i] {
                let sp = self.spawn(&rays[i], lit, depth, weights[i]);
                kinds[0] |= sp.reflection.is_some();
                kinds[1] |= sp.refraction.is_some();
                spawned[i] = Some(sp);
            }
        }
        // Reflections, then refractions: each colour gets the terms in shade()'s order.
        for refraction in [false, true] {
            if !kinds[usize::from(refraction)] {
                continue;
            }
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

impl Integrator<f32> {
    /// [`Integrator::trace_eye_block`] in lanes: the eye rays made straight into a [`RayPacket`],
    /// their hits by [`Accel::intersect_lanes`], each light's shadow rays made in lanes
    /// ([`shadow_lanes`]) and answered by [`Accel::occluded_lanes`]. The same rays, hits,
    /// colours and counts as the prepared rays.
    ///
    /// [`Accel::intersect_lanes`]: crate::accel::Accel::intersect_lanes
    /// [`Accel::occluded_lanes`]: crate::accel::Accel::occluded_lanes
    fn trace_eye_lanes(
        &self,
        camera: &Camera<f32>,
        (bx, by, bw, bh): (u32, u32, u32, u32),
        out: &mut [V3<f32>],
        buffers: &mut PacketBuffers,
        stats: &mut RayStats,
    ) {
        let PacketBuffers {
            eye,
            shadow,
            prepared,
        } = buffers;
        eye.eye(camera, bx, by, bw, bh);
        let n = eye.len();
        count_rays(RayKind::Eye, n, stats);
        let mut rays = [Ray {
            o: V3::zero(),
            d: V3::zero(),
            t_min: 0.0,
            t_max: 0.0,
        }; PACKET];
        for (i, r) in rays[..n].iter_mut().enumerate() {
            *r = eye.ray(i);
        }
        let rays = &rays[..n];
        let mut hits = [None; PACKET];
        // Rays a leaf test takes one by one are prepared into `prepared`, once per packet.
        let test = LanesLeaf::new(&self.scene, prepared);
        self.accel.intersect_lanes(eye, &mut hits[..n], stats, test);
        let lits = self.lits(rays, &hits[..n], RayKind::Eye, out, stats);
        self.lights_lanes(rays, &lits, prepared, shadow, out, stats);
        let weights = [1.0; PACKET];
        self.trace_secondary(rays, &lits, 1, &weights, out, stats);
    }

    /// Every light's term for a packet's lit hits (of `rays`), [`Integrator::add_light`] light
    /// by light, with each light's shadow rays made in lanes ([`shadow_lanes`]) and answered by
    /// [`Accel::occluded_lanes`] (rays a leaf takes one by one prepared into `prepared`): the
    /// same rays, answers, colours and counts as the prepared rays of [`Integrator::trace_packet`].
    ///
    /// [`Accel::occluded_lanes`]: crate::accel::Accel::occluded_lanes
    fn lights_lanes(
        &self,
        rays: &[Ray<f32>],
        lits: &[Option<Lit<f32>>; PACKET],
        prepared: &mut [PreparedRay<f32>; PACKET],
        shadow: &mut RayPacket,
        out: &mut [V3<f32>],
        stats: &mut RayStats,
    ) {
        let n = rays.len();
        let mut surfaces = SurfaceLanes::default();
        for (i, lit) in lits[..n].iter().enumerate() {
            if let Some(lit) = lit {
                surfaces.set(i, &lit.s);
            }
        }
        let mut owner = [0usize; PACKET];
        let mut toward = [(0.0, 0.0); PACKET];
        let mut occ = [false; PACKET];
        for (li, light) in self.scene.lights.iter().enumerate() {
            // The lanes that cast a shadow ray, by shadow_ray()'s test (the shading normal
            // towards the light, the light off the surface); shadow_lanes() then makes
            // shadow_ray()'s rays for exactly those lanes, in lane order.
            let mut mask = 0u32;
            let mut k = 0;
            for (i, lit) in lits[..n].iter().enumerate() {
                let Some(lit) = lit else { continue };
                let to_light = light.position - lit.s.p;
                let n_dot_l_raw = lit.ns.dot(to_light);
                if n_dot_l_raw <= 0.0 {
                    continue;
                }
                let dist = to_light.length();
                if !(dist > 0.0) {
                    continue;
                }
                mask |= 1 << i;
                owner[k] = i;
                toward[k] = (n_dot_l_raw, dist);
                k += 1;
            }
            surfaces.mask = mask;
            shadow_lanes(shadow, None, &surfaces, light.position);
            debug_assert_eq!(shadow.len(), k);
            if k > 0 {
                let test = LanesLeaf::new(&self.scene, prepared);
                self.accel
                    .occluded_lanes(shadow, &mut occ[..k], stats, test);
            }
            self.add_light(rays, lits, li, &occ[..k], &owner, &toward, out, stats);
        }
    }
}

/// `s` as a slice of `U` when `T` is `U`.
#[inline(always)]
fn same_slice<T: 'static, U: 'static>(s: &[T]) -> Option<&[U]> {
    if TypeId::of::<T>() == TypeId::of::<U>() {
        // SAFETY: `T` is `U`, so both slices have the same type.
        Some(unsafe { &*(s as *const [T] as *const [U]) })
    } else {
        None
    }
}

/// `s` as a mutable slice of `U` when `T` is `U`.
#[inline(always)]
fn same_slice_mut<T: 'static, U: 'static>(s: &mut [T]) -> Option<&mut [U]> {
    if TypeId::of::<T>() == TypeId::of::<U>() {
        // SAFETY: `T` is `U`, so both slices have the same type.
        Some(unsafe { &mut *(s as *mut [T] as *mut [U]) })
    } else {
        None
    }
}

/// Counts `n` rays of `kind` in `stats`.
fn count_rays(kind: RayKind, n: usize, stats: &mut RayStats) {
    match kind {
        RayKind::Eye => stats.eye_rays += n as u64,
        RayKind::Reflection => stats.reflection_rays += n as u64,
        RayKind::Refraction => stats.refraction_rays += n as u64,
    }
}

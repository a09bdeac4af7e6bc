//! Secondary and shadow rays traced as streams (issue 33): the eye rays of a run of 4 × 4 blocks
//! of a tile go in their block packets, then level by level the reflection and refraction rays
//! of the whole run are gathered, sorted so that neighbours point the same way, and traced in
//! packets of close rays (the rest one by one); each level's shadow rays go light by light,
//! sorted by their direction's octant and their origin. Every ray gets the answer it gets alone,
//! and the colours are summed bottom-up afterwards in the order [`Integrator::trace`] sums them
//! (ambient, the lights in turn, reflection × weight, refraction × weight), so every pixel is
//! the same bits as tracing its eye ray on its own. The buffers live in a [`Stream`] that is
//! reused from run to run: nothing is allocated per ray.

use crate::accel::bvh::packet::PACKET;
use crate::geometry::{PreparedRay, PrimHit, Ray};
use crate::packet_trace::{directions_close, SECONDARY_SPREAD};
use crate::real::Real;
use crate::shade::{Integrator, Lit, RayKind};
use crate::stats::RayStats;
use crate::vec3::V3;

/// Most 4 × 4 blocks of eye rays in one stream: enough rays (up to 1024) for sorting to find
/// rays that point the same way, few enough that a stream's buffers stay small at any tile size.
pub const STREAM_BLOCKS: usize = 256;

/// Blocks per stream (temporary knob).
pub fn stream_blocks() -> usize {
    let k = knobs().4;
    if k == 0 {
        64
    } else {
        k.min(STREAM_BLOCKS)
    }
}

/// Fewest close secondary rays traced as a packet; smaller groups go one by one.
pub const MIN_GROUP: usize = 4;

/// Most rays one level may hold, per eye ray of the stream; a level beyond it (a deep tree of
/// rays with the cut-off disabled) is traced by [`Integrator::trace`], depth first, so the
/// buffers stay bounded whatever the depth limit.
const LEVEL_LIMIT: usize = 16;

/// Temporary knobs for measuring (PARRT_STREAM="skey mg shadow ospread").
pub fn knobs() -> &'static (u32, usize, u32, f64, usize) {
    static K: std::sync::OnceLock<(u32, usize, u32, f64, usize)> = std::sync::OnceLock::new();
    K.get_or_init(|| {
        let v: Vec<String> = std::env::var("PARRT_STREAM")
            .unwrap_or_default()
            .split_whitespace()
            .map(String::from)
            .collect();
        let g = |i: usize, d: f64| v.get(i).and_then(|x| x.parse().ok()).unwrap_or(d);
        (
            g(0, 0.0) as u32,
            g(1, MIN_GROUP as f64) as usize,
            g(2, 1.0) as u32,
            g(3, 1e9),
            g(4, 0.0) as usize,
        )
    })
}

/// No child ray.
const NONE: u32 = u32::MAX;

/// One ray of the stream's tree.
#[derive(Clone, Copy, Debug)]
struct Node<R> {
    ray: Ray<R>,
    /// Product of the weights along the path to this ray.
    weight: R,
    /// Weight this ray's colour is added to its parent's with.
    w: R,
    /// Direct light at the hit, then the children's colours added.
    color: V3<R>,
    /// Index of the reflection child, or [`NONE`].
    refl: u32,
    /// Index of the refraction child, or [`NONE`].
    refr: u32,
    kind: RayKind,
}

/// The buffers of a stream of rays, kept from run to run (one per thread).
#[derive(Debug)]
pub struct Stream<R> {
    /// Every ray of the tree, level after level: children always after their parents.
    nodes: Vec<Node<R>>,
    /// End of each eye block in `nodes`.
    blocks: Vec<u32>,
    /// The current level's hits made ready for shading, by node relative to the level's start.
    lits: Vec<Option<Lit<R>>>,
    /// Sort keys: the key in the high 32 bits, an index in the low 32.
    keys: Vec<u64>,
    /// The current level's rays relative to its start, group after group.
    order: Vec<u32>,
    /// The current level's groups: start in `order`, length, traced as a packet.
    groups: Vec<(u32, u32, bool)>,
    /// The next level's rays as their parents' groups spawned them: start relative to the
    /// next level, length (the reflections of one group, or its refractions).
    natural: Vec<(u32, u32)>,
    /// `natural` while the level that reads it spawns the next.
    spare: Vec<(u32, u32)>,
    /// Temporary counters: leftover rays, leftover rays in packets, natural packet rays.
    pub counts: [u64; 3],
}

impl<R> Drop for Stream<R> {
    fn drop(&mut self) {
        if std::env::var_os("PARRT_STREAM_COUNT").is_some() {
            eprintln!("stream counts {:?}", self.counts);
        }
    }
}

/// The octant of a direction, one bit per negative component.
#[inline]
fn octant<R: Real>(d: V3<R>) -> u32 {
    (d.x < R::ZERO) as u32 | ((d.y < R::ZERO) as u32) << 1 | ((d.z < R::ZERO) as u32) << 2
}

/// Nine bits of `x` spread to every third bit.
#[inline]
fn spread3(x: u32) -> u32 {
    let mut x = x & 0x1ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

/// A Morton code of 27 bits for a point, each component given as a fraction of its range.
#[inline]
fn morton(f: [f64; 3]) -> u32 {
    // `as` saturates: NaN and out-of-range fractions land on the ends.
    let q = |v: f64| (v * 511.0) as u32;
    spread3(q(f[0])) | spread3(q(f[1])) << 1 | spread3(q(f[2])) << 2
}

/// The sort key of a secondary ray: its octant, then a Morton code of its direction.
#[inline]
fn direction_key<R: Real>(d: V3<R>) -> u32 {
    let f = |v: R| (v.to_f64() + 1.0) * 0.5;
    octant(d) << 27 | morton([f(d.x), f(d.y), f(d.z)])
}

/// Lower corner and inverse extent of a box around points, for [`morton`] fractions.
struct Frame {
    lo: [f64; 3],
    inv: [f64; 3],
}

impl Frame {
    fn around<R: Real>(points: impl Iterator<Item = V3<R>>) -> Frame {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in points {
            for (a, v) in [p.x, p.y, p.z].into_iter().enumerate() {
                lo[a] = lo[a].min(v.to_f64());
                hi[a] = hi[a].max(v.to_f64());
            }
        }
        let inv = std::array::from_fn(|a| {
            let e = hi[a] - lo[a];
            if e > 0.0 && e.is_finite() {
                1.0 / e
            } else {
                0.0
            }
        });
        Frame { lo, inv }
    }

    fn key<R: Real>(&self, p: V3<R>) -> u32 {
        let f = |a: usize, v: R| (v.to_f64() - self.lo[a]) * self.inv[a];
        morton([f(0, p.x), f(1, p.y), f(2, p.z)])
    }
}

impl<R: Real> Stream<R> {
    /// Empty buffers.
    pub fn new() -> Self {
        Stream {
            nodes: Vec::new(),
            blocks: Vec::new(),
            lits: Vec::new(),
            keys: Vec::new(),
            order: Vec::new(),
            groups: Vec::new(),
            natural: Vec::new(),
            spare: Vec::new(),
            counts: [0; 3],
        }
    }

    /// Forgets the last run's rays (keeping the buffers).
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.blocks.clear();
    }

    /// Eye blocks added since [`Stream::clear`].
    pub fn blocks(&self) -> usize {
        self.blocks.len()
    }

    /// Adds the eye rays of one block (at most [`PACKET`]), traced together as a packet.
    pub fn push_block(&mut self, rays: &[Ray<R>]) {
        assert!(rays.len() <= PACKET);
        for r in rays {
            self.nodes.push(Node {
                ray: *r,
                weight: R::ONE,
                w: R::ONE,
                color: V3::zero(),
                refl: NONE,
                refr: NONE,
                kind: RayKind::Eye,
            });
        }
        self.blocks.push(self.nodes.len() as u32);
    }

    /// The colours of the eye rays, in the order they were added; valid after
    /// [`Stream::trace`].
    pub fn eye_colors(&self) -> impl Iterator<Item = V3<R>> + '_ {
        let n = self.blocks.last().map_or(0, |&e| e as usize);
        self.nodes[..n].iter().map(|n| n.color)
    }

    /// Traces every ray added, and their shadow and secondary rays, level by level, then sums
    /// the colours bottom-up: each eye ray's colour is then the bits
    /// [`Integrator::trace`] gives it (depth 1, weight 1).
    pub fn trace(&mut self, integ: &Integrator<R>, stats: &mut RayStats) {
        let eyes = self.blocks.last().map_or(0, |&e| e as usize);
        let (mut start, mut end) = (0, eyes);
        let mut depth = 1;
        self.natural.clear();
        let mut from = 0;
        for &e in &self.blocks {
            self.natural.push((from, e - from));
            from = e;
        }
        while start < end {
            if end - start > LEVEL_LIMIT * eyes.max(PACKET) {
                for node in &mut self.nodes[start..end] {
                    node.color = integ.trace(&node.ray, depth, node.weight, node.kind, stats);
                }
                break;
            }
            self.trace_level(integ, start, end, depth, stats);
            (start, end) = (end, self.nodes.len());
            depth += 1;
        }
        // Children come after their parents: walking back, each child is complete before its
        // parent adds it, reflection first, as Integrator::shade adds them.
        for i in (0..self.nodes.len()).rev() {
            let Node { refl, refr, .. } = self.nodes[i];
            if refl != NONE {
                let c = &self.nodes[refl as usize];
                let add = c.color * c.w;
                self.nodes[i].color += add;
            }
            if refr != NONE {
                let c = &self.nodes[refr as usize];
                let add = c.color * c.w;
                self.nodes[i].color += add;
            }
        }
    }

    /// One level, `nodes[start..end]` at `depth`: groups, hits, direct light, and the
    /// secondary rays appended as the next level.
    fn trace_level(
        &mut self,
        integ: &Integrator<R>,
        start: usize,
        end: usize,
        depth: u32,
        stats: &mut RayStats,
    ) {
        let n = end - start;
        self.lits.clear();
        self.lits.resize(n, None);
        for node in &self.nodes[start..end] {
            match node.kind {
                RayKind::Eye => stats.eye_rays += 1,
                RayKind::Reflection => stats.reflection_rays += 1,
                RayKind::Refraction => stats.refraction_rays += 1,
            }
        }
        self.group(start, depth == 1);
        for g in 0..self.groups.len() {
            self.intersect_group(integ, start, g, stats);
        }
        for (node, lit) in self.nodes[start..end].iter_mut().zip(&self.lits) {
            node.color = match lit {
                None => integ.scene.background,
                Some(lit) => integ.ambient(lit),
            };
        }
        for g in 0..self.groups.len() {
            self.shadows(integ, start, g, stats);
        }
        std::mem::swap(&mut self.natural, &mut self.spare);
        self.natural.clear();
        if depth >= integ.opts.max_depth {
            return;
        }
        for g in 0..self.groups.len() {
            self.spawn(integ, start, end, g, depth);
        }
    }

    /// The level's groups from the groups its parents spawned (`self.natural`): the eye
    /// blocks, and every group of two or more whose directions are close
    /// ([`directions_close`]), as packets, as [`Integrator::trace_packet`] takes them; the
    /// rest sorted together and cut into runs of close rays (packets of at least
    /// [`MIN_GROUP`]) and single rays.
    fn group(&mut self, start: usize, eye: bool) {
        self.order.clear();
        self.groups.clear();
        self.keys.clear();
        for &(s, len) in &self.natural {
            let rays = &self.nodes[start + s as usize..start + (s + len) as usize];
            let close = eye
                || (len > 1 && {
                    let mut r = [rays[0].ray; PACKET];
                    for (r, n) in r.iter_mut().zip(rays) {
                        *r = n.ray;
                    }
                    directions_close(&r[..len as usize])
                });
            if close {
                if !eye {
                    self.counts[2] += len as u64;
                }
                self.groups.push((self.order.len() as u32, len, true));
                self.order.extend(s..s + len);
            } else {
                self.keys.extend((s..s + len).map(u64::from));
            }
        }
        if self.keys.is_empty() {
            return;
        }
        let (skey, min_group, _, ospread, _) = *knobs();
        for key in &mut self.keys {
            let node = &self.nodes[start + *key as usize];
            let k = if skey == 0 {
                direction_key(node.ray.d)
            } else {
                octant(node.ray.d) << 27
            };
            *key |= (k as u64) << 32;
        }
        if skey == 1 {
            let frame = Frame::around(
                self.keys
                    .iter()
                    .map(|&k| self.nodes[start + (k as u32) as usize].ray.o),
            );
            for key in &mut self.keys {
                let node = &self.nodes[start + (*key as u32) as usize];
                *key |= (frame.key(node.ray.o) as u64) << 32;
            }
        }
        self.keys.sort_unstable();
        let spread = R::from_f64(SECONDARY_SPREAD);
        let ospread = R::from_f64(ospread);
        let ray = |key: u64| self.nodes[start + (key as u32) as usize].ray;
        let mut i = 0;
        while i < self.keys.len() {
            let first = ray(self.keys[i]);
            let (mut lo, mut hi) = (first.d, first.d);
            let (mut olo, mut ohi) = (first.o, first.o);
            let mut j = i + 1;
            while j < self.keys.len() && j - i < PACKET && self.keys[j] >> 59 == self.keys[i] >> 59
            {
                let r = ray(self.keys[j]);
                let (l, h) = (lo.min(r.d), hi.max(r.d));
                let e = h - l;
                if e.x.max(e.y).max(e.z) > spread {
                    break;
                }
                let (ol, oh) = (olo.min(r.o), ohi.max(r.o));
                let e = oh - ol;
                if e.x.max(e.y).max(e.z) > ospread {
                    break;
                }
                (lo, hi, olo, ohi) = (l, h, ol, oh);
                j += 1;
            }
            let packet = j - i >= min_group.max(2);
            self.counts[0] += (j - i) as u64;
            if packet {
                self.counts[1] += (j - i) as u64;
            }
            self.groups
                .push((self.order.len() as u32, (j - i) as u32, packet));
            self.order.extend(self.keys[i..j].iter().map(|&k| k as u32));
            i = j;
        }
    }

    /// Closest hits of group `g`'s rays, as a packet or one by one; their lits into
    /// `self.lits`.
    fn intersect_group(
        &mut self,
        integ: &Integrator<R>,
        start: usize,
        g: usize,
        stats: &mut RayStats,
    ) {
        let (s, k, packet) = self.groups[g];
        let (s, k) = (s as usize, k as usize);
        let members = &self.order[s..s + k];
        let node = |i: u32| &self.nodes[start + i as usize];
        let mut hits: [Option<PrimHit<R>>; PACKET] = [None; PACKET];
        if packet {
            let mut prs = [PreparedRay::new(node(members[0]).ray); PACKET];
            for (pr, &i) in prs.iter_mut().zip(members).skip(1) {
                *pr = PreparedRay::new(node(i).ray);
            }
            integ.intersect_packet(&prs[..k], &mut hits[..k], stats);
        } else {
            for (h, &i) in hits.iter_mut().zip(members) {
                *h = integ.intersect(&node(i).ray, stats);
            }
        }
        for (h, &i) in hits[..k].iter().zip(members) {
            let Some(h) = h else {
                continue;
            };
            let node = &self.nodes[start + i as usize];
            match node.kind {
                RayKind::Eye => stats.eye_hits += 1,
                RayKind::Reflection => stats.reflection_hits += 1,
                RayKind::Refraction => stats.refraction_hits += 1,
            }
            self.lits[i as usize] = Some(integ.lit(&node.ray, h));
        }
    }

    /// The shadow rays of group `g`'s hits, light by light: a packet per light when the group
    /// went as a packet, one by one otherwise. The free ones add their light to their node's
    /// colour, the lights in turn, as [`Integrator::direct`] adds them.
    fn shadows(&mut self, integ: &Integrator<R>, start: usize, g: usize, stats: &mut RayStats) {
        let (s, k, packet) = self.groups[g];
        let members = &self.order[s as usize..(s + k) as usize];
        let Some(&first) = members.first() else {
            return;
        };
        let first = PreparedRay::new(self.nodes[start + first as usize].ray);
        let mut shadow = [first; PACKET];
        let mut owner = [0u32; PACKET];
        let mut toward = [(R::ZERO, R::ZERO); PACKET];
        let mut occ = [false; PACKET];
        for li in 0..integ.scene.lights.len() {
            let mut m = 0;
            for &i in members {
                if let Some((r, n_dot_l_raw, dist)) = self.lits[i as usize]
                    .as_ref()
                    .and_then(|l| integ.shadow_ray(l, li))
                {
                    shadow[m] = PreparedRay::new(r);
                    owner[m] = i;
                    toward[m] = (n_dot_l_raw, dist);
                    m += 1;
                }
            }
            if packet {
                integ.occluded_packet(&shadow[..m], &mut occ[..m], stats);
            } else {
                for (o, sh) in occ.iter_mut().zip(&shadow[..m]) {
                    *o = integ.occluded(&sh.ray, stats);
                }
            }
            stats.shadow_rays += m as u64;
            for j in 0..m {
                if occ[j] {
                    stats.shadow_hits += 1;
                    continue;
                }
                let i = owner[j] as usize;
                let Some(lit) = &self.lits[i] else {
                    continue;
                };
                let (n_dot_l_raw, dist) = toward[j];
                let node = &self.nodes[start + i];
                let add = integ.from_light(&node.ray, lit, li, n_dot_l_raw, dist);
                self.nodes[start + i].color += add;
            }
        }
    }

    /// The reflection and refraction rays of group `g`'s hits, appended to the next level:
    /// the reflections of the group together, then its refractions, each run a group of the
    /// next level's `self.natural`.
    fn spawn(&mut self, integ: &Integrator<R>, start: usize, end: usize, g: usize, depth: u32) {
        let (s, k, _) = self.groups[g];
        let (s, k) = (s as usize, k as usize);
        let mut spawned = [None; PACKET];
        for (sp, &i) in spawned.iter_mut().zip(&self.order[s..s + k]) {
            if let Some(lit) = &self.lits[i as usize] {
                let node = &self.nodes[start + i as usize];
                *sp = Some(integ.spawn(&node.ray, lit, depth, node.weight));
            }
        }
        for kind in [RayKind::Reflection, RayKind::Refraction] {
            let first = self.nodes.len();
            for (j, sp) in spawned[..k].iter().enumerate() {
                let ray = sp.and_then(|sp| match kind {
                    RayKind::Reflection => sp.reflection,
                    _ => sp.refraction,
                });
                let Some((ray, w)) = ray else {
                    continue;
                };
                let parent = start + self.order[s + j] as usize;
                let child = self.nodes.len() as u32;
                self.nodes.push(Node {
                    ray,
                    weight: self.nodes[parent].weight * w,
                    w,
                    color: V3::zero(),
                    refl: NONE,
                    refr: NONE,
                    kind,
                });
                let p = &mut self.nodes[parent];
                match kind {
                    RayKind::Reflection => p.refl = child,
                    _ => p.refr = child,
                }
            }
            let len = self.nodes.len() - first;
            if len > 0 {
                self.natural.push(((first - end) as u32, len as u32));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_codes_interleave_the_axes() {
        assert_eq!(spread3(0b111), 0b1001001);
        assert_eq!(morton([0.0; 3]), 0);
        assert_eq!(morton([1.0; 3]), (1 << 27) - 1);
        // x is the lowest bit of each triple.
        assert_eq!(morton([1.0 / 511.0, 0.0, 0.0]), 1);
        assert_eq!(morton([0.0, 1.0 / 511.0, 0.0]), 2);
        assert_eq!(morton([f64::NAN, -1.0, 2.0]), spread3(511) << 2);
    }

    #[test]
    fn direction_keys_start_with_the_octant() {
        let key = |x, y, z| direction_key(V3::<f32>::new(x, y, z)) >> 27;
        assert_eq!(key(1.0, 1.0, 1.0), 0);
        assert_eq!(key(-1.0, 1.0, 1.0), 1);
        assert_eq!(key(1.0, -1.0, -1.0), 6);
    }
}

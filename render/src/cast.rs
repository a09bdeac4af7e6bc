//! Casting only, for comparing raw ray throughput with other kernels (Embree's `nffcast`): one eye
//! ray through each pixel centre and, for every hit, one shadow ray per light — to every light,
//! or (culling) only to lights in front of the surface. No shading, no secondary rays. The rays
//! go in 4 × 4 packets like a render's eye rays, or one by one. In `f32` on the `avx2` and
//! `avx512` tiers, a packet's rays live in lanes
//! ([`RayPacket`](crate::geometry::ray_packet::RayPacket), one set for a tile's packets,
//! [`PacketBuffers`]) from the camera through the traversal and the leaf kernels, and each
//! light's shadow packet is made in lanes from the hits ([`crate::packet::shadow`]); the other
//! tiers trace prepared rays. Both give the same rays, hits and counts.

use std::any::Any;

use crate::accel::bvh::packet::PACKET;
use crate::camera::Camera;
use crate::geometry::{offset_ray_origin, PreparedRay, Ray};
use crate::packet::buffers::PacketBuffers;
use crate::packet::leaf::LanesLeaf;
use crate::packet::shadow::{shadow_lanes, SurfaceLanes};
use crate::real::Real;
use crate::scene::Surface;
use crate::shade::Integrator;
use crate::stats::RayStats;
use crate::tile::Tile;
use crate::vec3::V3;

/// The shadow ray from the surface `s` hit by `ray` to the light at `position`, or `None` when
/// culled or the light sits on the surface.
#[inline]
pub(crate) fn shadow_ray<R: Real>(
    position: V3<R>,
    ray: &Ray<R>,
    s: &Surface<R>,
    cull: bool,
) -> Option<Ray<R>> {
    let ng = s.ng.face_forward(-ray.d);
    let to_light = position - s.p;
    if cull && ng.dot(to_light) <= R::ZERO {
        return None;
    }
    let dist = to_light.length();
    if !(dist > R::ZERO) {
        return None;
    }
    let o = offset_ray_origin(s.p, s.p_err, s.ng, to_light / dist);
    let d = position - o;
    let len = d.length();
    Some(Ray {
        o,
        d: d / len,
        t_min: R::ZERO,
        t_max: len,
    })
}

/// Casts the rays of one tile; counts go to `stats` (eye and shadow rays and hits).
pub fn cast_tile<R: Real>(
    integrator: &Integrator<R>,
    camera: &Camera<R>,
    tile: &Tile,
    cull: bool,
    packets: bool,
    stats: &mut RayStats,
) {
    let eye = |x: u32, y: u32| camera.ray(R::from_u32(x) + R::HALF, R::from_u32(y) + R::HALF);
    let lights = integrator.scene.lights.len();
    if !packets {
        for y in tile.y..tile.y + tile.h {
            for x in tile.x..tile.x + tile.w {
                let ray = eye(x, y);
                stats.eye_rays += 1;
                let Some(hit) = integrator.intersect(&ray, stats) else {
                    continue;
                };
                stats.eye_hits += 1;
                let s = integrator.scene.surface(&ray, &hit);
                for light in 0..lights {
                    if let Some(shadow) =
                        shadow_ray(integrator.scene.lights[light].position, &ray, &s, cull)
                    {
                        stats.shadow_rays += 1;
                        if integrator.occluded(&shadow, stats) {
                            stats.shadow_hits += 1;
                        }
                    }
                }
            }
        }
        return;
    }
    // The lanes pay on the `avx512` and `avx2` tiers (BENCHMARKS.md, *Per instruction-set
    // tier*); on `scalar` they cost 0.92–0.95 × the rays a second, so below `avx2` the tiers
    // keep the prepared rays.
    if let (Some(integrator), Some(camera), true) = (
        (integrator as &dyn Any).downcast_ref::<Integrator<f32>>(),
        (camera as &dyn Any).downcast_ref::<Camera<f32>>(),
        crate::isa::current().avx(),
    ) {
        return cast_tile_lanes(integrator, camera, tile, cull, stats);
    }
    let mut rays = [PreparedRay::new(eye(tile.x, tile.y)); PACKET];
    let mut hits = [None; PACKET];
    let mut surfaces = [None; PACKET];
    // Made once: every light's packet overwrites what it uses (occluded_packet writes every
    // answer).
    let mut shadow = rays;
    let mut occ = [false; PACKET];
    // One slot of lanes for every packet of the tile (PacketLeaf).
    let mut lanes = None;
    for (bx, by, bw, bh) in tile.blocks() {
        let mut n = 0;
        for y in by..by + bh {
            for x in bx..bx + bw {
                rays[n] = PreparedRay::new(eye(x, y));
                n += 1;
            }
        }
        stats.eye_rays += n as u64;
        integrator.intersect_packet(&rays[..n], &mut hits[..n], &mut lanes, stats);
        for i in 0..n {
            surfaces[i] = hits[i].map(|h| integrator.scene.surface(&rays[i].ray, &h));
        }
        for light in 0..lights {
            let mut k = 0;
            for i in 0..n {
                let Some(s) = &surfaces[i] else { continue };
                if let Some(r) = shadow_ray(
                    integrator.scene.lights[light].position,
                    &rays[i].ray,
                    s,
                    cull,
                ) {
                    shadow[k] = PreparedRay::new(r);
                    k += 1;
                }
            }
            integrator.occluded_packet(&shadow[..k], &mut occ[..k], &mut lanes, stats);
            stats.shadow_rays += k as u64;
            stats.shadow_hits += occ[..k].iter().filter(|&&o| o).count() as u64;
        }
        stats.eye_hits += hits[..n].iter().filter(|h| h.is_some()).count() as u64;
    }
}

/// [`cast_tile`]'s packets in `f32`, their rays in lanes: the same rays, hits and counts.
fn cast_tile_lanes(
    integrator: &Integrator<f32>,
    camera: &Camera<f32>,
    tile: &Tile,
    cull: bool,
    stats: &mut RayStats,
) {
    let scene = &integrator.scene;
    let accel = &integrator.accel;
    // The tile's packets work in one set of lanes, as a render's do; rays a leaf test takes
    // one by one are prepared into `prepared`, once per packet.
    let PacketBuffers {
        eye,
        shadow,
        prepared,
    } = &mut PacketBuffers::new();
    let mut hits = [None; PACKET];
    let mut surfaces = SurfaceLanes::default();
    let mut occ = [false; PACKET];
    for (bx, by, bw, bh) in tile.blocks() {
        eye.eye(camera, bx, by, bw, bh);
        let n = eye.len();
        stats.eye_rays += n as u64;
        let test = LanesLeaf::new(scene, prepared);
        accel.intersect_lanes(eye, &mut hits[..n], stats, test);
        surfaces.mask = 0;
        for (i, h) in hits[..n].iter().enumerate() {
            if let Some(h) = h {
                surfaces.set(i, &scene.surface(&eye.ray(i), h));
            }
        }
        for light in &scene.lights {
            shadow_lanes(
                shadow,
                cull.then_some(&eye.tri.d),
                &surfaces,
                light.position,
            );
            let k = shadow.len();
            if k == 0 {
                continue;
            }
            let test = LanesLeaf::new(scene, prepared);
            accel.occluded_lanes(shadow, &mut occ[..k], stats, test);
            stats.shadow_rays += k as u64;
            stats.shadow_hits += occ[..k].iter().filter(|&&o| o).count() as u64;
        }
        stats.eye_hits += hits[..n].iter().filter(|h| h.is_some()).count() as u64;
    }
}

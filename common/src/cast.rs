//! Casting only, for comparing raw ray throughput with other kernels (Embree's `nffcast`): one eye
//! ray through each pixel centre and, for every hit, one shadow ray per light — to every light,
//! or (culling) only to lights in front of the surface. No shading, no secondary rays.

use crate::camera::Camera;
use crate::geometry::{offset_ray_origin, Ray};
use crate::real::Real;
use crate::shade::Integrator;
use crate::stats::RayStats;
use crate::tile::Tile;

/// Casts the rays of one tile; counts go to `stats` (eye and shadow rays and hits).
pub fn cast_tile<R: Real>(
    integrator: &Integrator<R>,
    camera: &Camera<R>,
    tile: &Tile,
    cull: bool,
    stats: &mut RayStats,
) {
    let scene = &integrator.scene;
    for y in tile.y..tile.y + tile.h {
        for x in tile.x..tile.x + tile.w {
            let half = R::HALF;
            let ray = camera.ray(R::from_u32(x) + half, R::from_u32(y) + half);
            stats.eye_rays += 1;
            let Some(hit) = integrator.intersect(&ray, stats) else {
                continue;
            };
            stats.eye_hits += 1;
            let s = scene.surface(&ray, &hit);
            let ng = s.ng.face_forward(-ray.d);
            for light in &scene.lights {
                let to_light = light.position - s.p;
                if cull && ng.dot(to_light) <= R::ZERO {
                    continue;
                }
                let dist = to_light.length();
                if !(dist > R::ZERO) {
                    continue;
                }
                let o = offset_ray_origin(s.p, s.p_err, s.ng, to_light / dist);
                let d = light.position - o;
                let len = d.length();
                let shadow = Ray {
                    o,
                    d: d / len,
                    t_min: R::ZERO,
                    t_max: len,
                };
                stats.shadow_rays += 1;
                if integrator.occluded(&shadow, stats) {
                    stats.shadow_hits += 1;
                }
            }
        }
    }
}

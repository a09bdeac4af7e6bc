//! Geometry: rays, boxes, the primitives' intersection routines and hit records. Every
//! intersectable answers two queries: the closest hit (`intersect`) and any hit (`occluded`).
//! Nothing here allocates.

pub mod aabb;
pub mod cone;
pub mod hit;
pub mod hits4;
pub mod lanes16;
pub mod leaf16;
pub mod ray;
pub mod slab;
pub mod sphere;
pub mod sphere4;
pub mod triangle;
pub mod triangle4;
pub mod triangulate;

pub use aabb::Aabb;
pub use hit::{offset_ray_origin, Nearest, PrimHit};
pub use ray::{PreparedRay, Ray};

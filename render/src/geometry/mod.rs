//! Geometry: rays, boxes, the primitives' intersection routines and hit records. Every
//! intersectable answers two queries: the closest hit (`intersect`) and any hit (`occluded`).
//! Nothing here allocates.
//!
//! - [`ray`], [`hit`]: rays and their prepared form; hit records and the nearest-hit rule.
//! - [`aabb`], [`slab`]: boxes, and the slab test written once (scalar, a node's eight boxes,
//!   a packet's sixteen rays).
//! - [`triangle`], [`sphere`], [`cone`]: each primitive's scalar test and error bound.
//! - [`leaf_triangles`], [`leaf_spheres`]: one ray against a leaf's four triangles or spheres
//!   in lanes ([`cone::lanes`] the cones'); [`four_lanes`] the one entry and dispatch of those
//!   four-lane kernels; [`distance_hits`] the answers of the kernels that find only distances
//!   and their portable loop.
//! - [`ray_packet`], [`packet_prims`]: a packet's rays in lanes, and the packet against one
//!   triangle, sphere or cone (one kernel per primitive, [`packet_prims::PacketShape`]).
//! - [`triangulate`]: polygons into triangles.

pub mod aabb;
pub mod cone;
pub mod distance_hits;
pub mod four_lanes;
pub mod hit;
pub mod leaf_spheres;
pub mod leaf_triangles;
pub mod packet_prims;
pub mod ray;
pub mod ray_packet;
pub mod slab;
pub mod sphere;
#[cfg(test)]
mod test_coords;
pub mod triangle;
pub mod triangulate;

pub use aabb::Aabb;
pub use hit::{offset_ray_origin, Nearest, PrimHit};
pub use ray::{PreparedRay, Ray};

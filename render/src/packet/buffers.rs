//! A packet's working memory, made once for a tile's packets instead of once per packet: the
//! eye rays' lanes, the shadow rays' lanes and the rays a leaf takes one by one. Every packet
//! overwrites the lanes it uses before reading them (the eye and shadow lanes are made whole,
//! past-the-end lanes repeating lane 0; a prepared ray is read only once made for this packet),
//! so what a buffer held before never reaches an answer. Made per packet, their zeroing was
//! a twentieth of a sparse scene's render (tetra-6).

use crate::accel::bvh::packet::PACKET;
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::{PreparedRay, Ray};
use crate::vec3::V3;

/// The lanes and prepared rays an eye packet and its shadow packets work in.
#[derive(Debug)]
pub struct PacketBuffers {
    /// The eye rays of a 4 × 4 block.
    pub(crate) eye: RayPacket,
    /// One light's shadow rays of the eye rays' hits.
    pub(crate) shadow: RayPacket,
    /// The rays a leaf test takes one by one, prepared from the lanes when first needed.
    pub(crate) prepared: [PreparedRay<f32>; PACKET],
}

impl PacketBuffers {
    /// Buffers for a tile's packets (their contents are filler until a packet writes them).
    pub fn new() -> Self {
        PacketBuffers {
            eye: RayPacket::new(),
            shadow: RayPacket::new(),
            prepared: [PreparedRay::new(Ray {
                o: V3::zero(),
                d: V3::new(0.0, 0.0, 1.0),
                t_min: 0.0,
                t_max: 0.0,
            }); PACKET],
        }
    }
}

impl Default for PacketBuffers {
    fn default() -> Self {
        Self::new()
    }
}

//! Rays in packets: the eye rays of a 4 × 4 pixel block and the shadow, reflection and
//! refraction rays they make ([`trace`]), a packet's rays against a leaf, a ray per lane
//! ([`leaf`]), and a packet's shadow rays towards one light made sixteen lanes at a time
//! ([`shadow`]), and the scene's primitive test as the accelerators call it, one ray against
//! four primitives at a time or a packet against a leaf ([`scene_leaf`]).

pub mod buffers;
pub mod leaf;
pub mod scene_leaf;
pub mod shadow;
pub mod trace;

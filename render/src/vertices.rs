//! A polygon's vertex list ([`crate::description::Shape::Polygon`]): a triangle's three vertices
//! are stored inline and any other count in a vector, so a triangle costs its primitive's 88
//! bytes instead of an 80-byte primitive plus an 80-byte heap block. It reads as a slice of
//! vertices and is written and read (serde) as the sequence the `Vec` it replaced was, so NFF and
//! the wire form are unchanged.

use crate::vec3::Vec3d;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::ops::{Deref, DerefMut};

/// The vertices of a polygon, in order.
#[derive(Clone)]
pub struct Vertices(Repr);

#[derive(Clone)]
enum Repr {
    Triangle([Vec3d; 3]),
    Other(Vec<Vec3d>),
}

impl From<Vec<Vec3d>> for Vertices {
    fn from(v: Vec<Vec3d>) -> Self {
        match <[Vec3d; 3]>::try_from(v.as_slice()) {
            Ok(t) => Vertices(Repr::Triangle(t)),
            Err(_) => Vertices(Repr::Other(v)),
        }
    }
}

impl From<[Vec3d; 3]> for Vertices {
    fn from(t: [Vec3d; 3]) -> Self {
        Vertices(Repr::Triangle(t))
    }
}

impl FromIterator<Vec3d> for Vertices {
    fn from_iter<I: IntoIterator<Item = Vec3d>>(iter: I) -> Self {
        Vertices::from(iter.into_iter().collect::<Vec<_>>())
    }
}

impl Deref for Vertices {
    type Target = [Vec3d];
    fn deref(&self) -> &[Vec3d] {
        match &self.0 {
            Repr::Triangle(t) => t,
            Repr::Other(v) => v,
        }
    }
}

impl DerefMut for Vertices {
    fn deref_mut(&mut self) -> &mut [Vec3d] {
        match &mut self.0 {
            Repr::Triangle(t) => t,
            Repr::Other(v) => v,
        }
    }
}

impl<'a> IntoIterator for &'a Vertices {
    type Item = &'a Vec3d;
    type IntoIter = std::slice::Iter<'a, Vec3d>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl PartialEq for Vertices {
    fn eq(&self, o: &Self) -> bool {
        **self == **o
    }
}

impl std::fmt::Debug for Vertices {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl Serialize for Vertices {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.iter())
    }
}

impl<'de> Deserialize<'de> for Vertices {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Vec::<Vec3d>::deserialize(d).map(Vertices::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::{Primitive, Shape};

    fn v(x: f64) -> Vec3d {
        Vec3d::new(x, 2.0 * x, 3.0 * x)
    }

    #[test]
    fn a_triangle_primitive_takes_88_bytes_and_no_heap_block() {
        assert_eq!(std::mem::size_of::<Primitive>(), 88);
        let t = Vertices::from(vec![v(1.0), v(2.0), v(3.0)]);
        assert!(matches!(t.0, Repr::Triangle(_)));
        assert_eq!(&*t, &[v(1.0), v(2.0), v(3.0)]);
    }

    #[test]
    fn the_serialized_form_is_that_of_the_vector() {
        for n in [0, 1, 2, 3, 4, 7] {
            let vs: Vec<Vec3d> = (0..n).map(|i| v(i as f64)).collect();
            let old = postcard::to_allocvec(&vs).expect("vec");
            let new = postcard::to_allocvec(&Vertices::from(vs.clone())).expect("vertices");
            assert_eq!(old, new, "{n} vertices");
            let back: Vertices = postcard::from_bytes(&new).expect("read back");
            assert_eq!(&*back, &vs[..]);
            let shape = Shape::Polygon(vs.into());
            let again: Shape = postcard::from_bytes(&postcard::to_allocvec(&shape).expect("shape"))
                .expect("shape back");
            assert_eq!(again, shape);
        }
    }
}

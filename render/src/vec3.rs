//! A three-component vector generic over [`Real`]: points, directions, normals and linear RGB.
//! Plain arithmetic only; no allocation, no hidden normalisation.

use crate::real::Real;
use serde::{Deserialize, Serialize};
use std::ops::{Add, AddAssign, Div, Index, Mul, MulAssign, Neg, Sub, SubAssign};

/// A vector of three scalars.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct V3<R> {
    /// First component.
    pub x: R,
    /// Second component.
    pub y: R,
    /// Third component.
    pub z: R,
}

/// A vector of `f64`, the precision of scene descriptions.
pub type Vec3d = V3<f64>;

impl<R: Real> V3<R> {
    /// Builds a vector from components.
    #[inline(always)]
    pub const fn new(x: R, y: R, z: R) -> Self {
        V3 { x, y, z }
    }
    /// The zero vector.
    #[inline(always)]
    pub fn zero() -> Self {
        V3::new(R::ZERO, R::ZERO, R::ZERO)
    }
    /// All three components equal to `v`.
    #[inline(always)]
    pub fn splat(v: R) -> Self {
        V3::new(v, v, v)
    }
    /// Converts from an `f64` vector, rounding each component to nearest.
    #[inline(always)]
    pub fn from_f64(v: V3<f64>) -> Self {
        V3::new(R::from_f64(v.x), R::from_f64(v.y), R::from_f64(v.z))
    }
    /// Converts to an `f64` vector exactly.
    #[inline(always)]
    pub fn to_f64(self) -> V3<f64> {
        V3::new(self.x.to_f64(), self.y.to_f64(), self.z.to_f64())
    }
    /// Converts to an `f32` vector, rounding to nearest.
    #[inline(always)]
    pub fn to_f32(self) -> V3<f32> {
        V3::new(self.x.to_f32(), self.y.to_f32(), self.z.to_f32())
    }
    /// Converts from an array.
    #[inline(always)]
    pub fn from_array(a: [R; 3]) -> Self {
        V3::new(a[0], a[1], a[2])
    }
    /// Converts to an array.
    #[inline(always)]
    pub fn to_array(self) -> [R; 3] {
        [self.x, self.y, self.z]
    }
    /// Dot product.
    #[inline(always)]
    pub fn dot(self, o: Self) -> R {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// Cross product (right-handed).
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    /// Squared length.
    #[inline(always)]
    pub fn length_squared(self) -> R {
        self.dot(self)
    }
    /// Length.
    #[inline(always)]
    pub fn length(self) -> R {
        self.length_squared().sqrt()
    }
    /// The vector scaled to unit length. A zero vector gives NaNs: callers check first.
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * (R::ONE / self.length())
    }
    /// Component-wise absolute value.
    #[inline(always)]
    pub fn abs(self) -> Self {
        V3::new(self.x.abs(), self.y.abs(), self.z.abs())
    }
    /// Component-wise minimum.
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        V3::new(self.x.min(o.x), self.y.min(o.y), self.z.min(o.z))
    }
    /// Component-wise maximum.
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        V3::new(self.x.max(o.x), self.y.max(o.y), self.z.max(o.z))
    }
    /// Component-wise product.
    #[inline(always)]
    pub fn mul_elem(self, o: Self) -> Self {
        V3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    /// Largest component.
    #[inline(always)]
    pub fn max_component(self) -> R {
        self.x.max(self.y).max(self.z)
    }
    /// Index (0, 1, 2) of the component with the largest absolute value.
    #[inline(always)]
    pub fn max_abs_axis(self) -> usize {
        let a = self.abs();
        if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        }
    }
    /// True when every component is finite.
    #[inline(always)]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// Component `i` (0, 1 or 2).
    #[inline(always)]
    pub fn get(self, i: usize) -> R {
        match i {
            0 => self.x,
            1 => self.y,
            _ => self.z,
        }
    }
    /// Returns `self` flipped, if needed, to lie in the same hemisphere as `v`.
    #[inline(always)]
    pub fn face_forward(self, v: Self) -> Self {
        if self.dot(v) < R::ZERO {
            -self
        } else {
            self
        }
    }
}

impl<R: Real> Index<usize> for V3<R> {
    type Output = R;
    #[inline(always)]
    fn index(&self, i: usize) -> &R {
        match i {
            0 => &self.x,
            1 => &self.y,
            _ => &self.z,
        }
    }
}

/// `V3 op V3` component by component, and `op=` as `a = a op b`.
macro_rules! componentwise {
    ($Op:ident::$op:ident, $OpAssign:ident::$op_assign:ident, $sym:tt) => {
        impl<R: Real> $Op for V3<R> {
            type Output = Self;
            #[inline(always)]
            fn $op(self, o: Self) -> Self {
                V3::new(self.x $sym o.x, self.y $sym o.y, self.z $sym o.z)
            }
        }
        impl<R: Real> $OpAssign for V3<R> {
            #[inline(always)]
            fn $op_assign(&mut self, o: Self) {
                *self = *self $sym o;
            }
        }
    };
}
componentwise!(Add::add, AddAssign::add_assign, +);
componentwise!(Sub::sub, SubAssign::sub_assign, -);

impl<R: Real> Neg for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        V3::new(-self.x, -self.y, -self.z)
    }
}
impl<R: Real> Mul<R> for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: R) -> Self {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}
impl<R: Real> MulAssign<R> for V3<R> {
    #[inline(always)]
    fn mul_assign(&mut self, s: R) {
        *self = *self * s;
    }
}
impl<R: Real> Div<R> for V3<R> {
    type Output = Self;
    #[inline(always)]
    fn div(self, s: R) -> Self {
        V3::new(self.x / s, self.y / s, self.z / s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_is_right_handed() {
        let x = V3::new(1.0f64, 0.0, 0.0);
        let y = V3::new(0.0, 1.0, 0.0);
        assert_eq!(x.cross(y), V3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn max_abs_axis_picks_dominant() {
        assert_eq!(V3::new(0.1f32, -3.0, 2.0).max_abs_axis(), 1);
        assert_eq!(V3::new(0.0f32, 0.0, -1.0).max_abs_axis(), 2);
    }
}

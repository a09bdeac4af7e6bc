//! The pinhole camera of the NFF view (docs/design-rendering.md, *Camera*): `angle` spans the
//! image's shorter side edge to edge, pixels are square, screen-right = normalize((at − from) ×
//! up). Image coordinates are continuous: pixel (x, y) covers [x, x+1) × [y, y+1), row 0 at the
//! top.

use crate::description::View;
use crate::geometry::Ray;
use crate::real::Real;
use crate::vec3::V3;

/// A camera in the renderer's precision.
#[derive(Clone, Copy, Debug)]
pub struct Camera<R> {
    /// Eye position.
    pub eye: V3<R>,
    /// Unit view direction.
    pub forward: V3<R>,
    /// Unit screen-right.
    pub right: V3<R>,
    /// Unit screen-up.
    pub up: V3<R>,
    /// Side of one pixel on the image plane at unit distance.
    pub pixel: R,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Primary rays ignore hits nearer than this.
    pub hither: R,
}

impl<R: Real> Camera<R> {
    /// The camera of `view` for an image of `width × height`, in world coordinates. The view is
    /// assumed valid (the parser rejects degenerate ones); a degenerate view gives NaN
    /// directions, which trace as background.
    pub fn new(view: &View, width: u32, height: u32) -> Self {
        Self::in_frame(view, width, height, V3::zero())
    }

    /// Like [`Camera::new`], with the eye relative to the frame `origin` ([`crate::frame`]),
    /// subtracted in `f64`; the directions do not depend on the origin.
    pub fn in_frame(view: &View, width: u32, height: u32, origin: V3<f64>) -> Self {
        let from = view.from;
        let w = (view.at - from).normalize();
        let u = w.cross(view.up).normalize();
        let v = u.cross(w);
        let shorter = width.min(height).max(1) as f64;
        let half = (view.angle.to_radians() * 0.5).tan();
        Camera {
            eye: V3::from_f64(from - origin),
            forward: V3::from_f64(w),
            right: V3::from_f64(u),
            up: V3::from_f64(v),
            pixel: R::from_f64(2.0 * half / shorter),
            width,
            height,
            hither: R::from_f64(view.hither.max(0.0)),
        }
    }

    /// The eye ray through continuous image position `(sx, sy)`.
    #[inline]
    pub fn ray(&self, sx: R, sy: R) -> Ray<R> {
        let cx = sx - R::from_u32(self.width) * R::HALF;
        let cy = R::from_u32(self.height) * R::HALF - sy;
        let d = self.forward + self.right * (cx * self.pixel) + self.up * (cy * self.pixel);
        Ray {
            o: self.eye,
            d: d.normalize(),
            t_min: self.hither,
            t_max: R::INFINITY,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view() -> View {
        View {
            from: V3::new(0.0, 0.0, 0.0),
            at: V3::new(0.0, 1.0, 0.0),
            up: V3::new(0.0, 0.0, 1.0),
            angle: 90.0,
            hither: 0.0,
            width: 100,
            height: 100,
        }
    }

    #[test]
    fn centre_and_edges() {
        let c: Camera<f64> = Camera::new(&view(), 100, 100);
        let mid = c.ray(50.0, 50.0);
        assert!((mid.d - V3::new(0.0, 1.0, 0.0)).length() < 1e-12);
        // Right edge at 45°: screen-right = forward × up = +x.
        let r = c.ray(100.0, 50.0);
        assert!((r.d - V3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-12);
        let top = c.ray(50.0, 0.0);
        assert!((top.d - V3::new(0.0, 1.0, 1.0).normalize()).length() < 1e-12);
    }

    #[test]
    fn wide_image_angle_spans_height() {
        let c: Camera<f64> = Camera::new(&view(), 200, 100);
        let top = c.ray(100.0, 0.0);
        assert!((top.d - V3::new(0.0, 1.0, 1.0).normalize()).length() < 1e-12);
    }
}

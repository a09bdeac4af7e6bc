//! Affine 3D transforms for the generators, in SPD's row-vector convention (`p' = p·M`, so
//! `a.then(b)` applies `a` first). Angles are in degrees. Only +, −, ×, ÷, sqrt and std trig.

use parrt_render::vec3::Vec3d;

/// A 4×4 affine matrix whose last column is (0, 0, 0, 1); rows 0–2 hold the linear part,
/// row 3 the translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mat4 {
    m: [[f64; 3]; 4],
}

impl Mat4 {
    /// The identity.
    pub fn identity() -> Self {
        Mat4 {
            m: [
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 0.0],
            ],
        }
    }

    /// A translation by `t`.
    pub fn translate(t: Vec3d) -> Self {
        let mut r = Mat4::identity();
        r.m[3] = [t.x, t.y, t.z];
        r
    }

    /// A uniform scale.
    pub fn scale(s: f64) -> Self {
        let mut r = Mat4::identity();
        for i in 0..3 {
            r.m[i][i] = s;
        }
        r
    }

    /// A right-handed rotation by `deg` degrees about axis `axis` (0 = x, 1 = y, 2 = z):
    /// counter-clockwise looking from the positive axis toward the origin.
    pub fn rotate(axis: usize, deg: f64) -> Self {
        let (s, c) = deg.to_radians().sin_cos();
        let (a, b) = match axis {
            0 => (1, 2),
            1 => (2, 0),
            _ => (0, 1),
        };
        let mut r = Mat4::identity();
        // Row vectors: e_a ↦ c·e_a + s·e_b, e_b ↦ −s·e_a + c·e_b.
        r.m[a][a] = c;
        r.m[a][b] = s;
        r.m[b][a] = -s;
        r.m[b][b] = c;
        r
    }

    /// A matrix whose rows are the images of the x, y and z unit vectors (plus a translation).
    pub fn from_rows(x: Vec3d, y: Vec3d, z: Vec3d, t: Vec3d) -> Self {
        Mat4 {
            m: [
                [x.x, x.y, x.z],
                [y.x, y.y, y.z],
                [z.x, z.y, z.z],
                [t.x, t.y, t.z],
            ],
        }
    }

    /// `self` followed by `next` (the product `self·next`).
    pub fn then(&self, next: &Mat4) -> Mat4 {
        let mut r = [[0.0; 3]; 4];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.m[i][0] * next.m[0][j]
                    + self.m[i][1] * next.m[1][j]
                    + self.m[i][2] * next.m[2][j];
                if i == 3 {
                    *v += next.m[3][j];
                }
            }
        }
        Mat4 { m: r }
    }

    /// Transforms a point.
    pub fn point(&self, p: Vec3d) -> Vec3d {
        let m = &self.m;
        Vec3d::new(
            p.x * m[0][0] + p.y * m[1][0] + p.z * m[2][0] + m[3][0],
            p.x * m[0][1] + p.y * m[1][1] + p.z * m[2][1] + m[3][1],
            p.x * m[0][2] + p.y * m[1][2] + p.z * m[2][2] + m[3][2],
        )
    }

    /// Transforms a direction (no translation).
    pub fn vector(&self, p: Vec3d) -> Vec3d {
        let m = &self.m;
        Vec3d::new(
            p.x * m[0][0] + p.y * m[1][0] + p.z * m[2][0],
            p.x * m[0][1] + p.y * m[1][1] + p.z * m[2][1],
            p.x * m[0][2] + p.y * m[1][2] + p.z * m[2][2],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3d, b: Vec3d) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn rotations_are_right_handed() {
        let x = Vec3d::new(1.0, 0.0, 0.0);
        let y = Vec3d::new(0.0, 1.0, 0.0);
        let z = Vec3d::new(0.0, 0.0, 1.0);
        assert!(close(Mat4::rotate(2, 90.0).point(x), y));
        assert!(close(Mat4::rotate(0, 90.0).point(y), z));
        assert!(close(Mat4::rotate(1, 90.0).point(z), x));
    }

    #[test]
    fn then_applies_left_first() {
        let m = Mat4::translate(Vec3d::new(1.0, 0.0, 0.0)).then(&Mat4::rotate(2, 90.0));
        assert!(close(m.point(Vec3d::zero()), Vec3d::new(0.0, 1.0, 0.0)));
    }
}

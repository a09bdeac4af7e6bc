//! `soup`: a triangle soup with thin slivers, not an SPD scene: 1000·N unconnected triangles in
//! the cube [−1, 1]³ over a floor, a third of them needles (two long edges, a width of 10⁻⁴ to
//! 10⁻² of their length) and a third caps (a height as thin), the rest ordinary. The hard case
//! for precision: features down to 10⁻⁴ of the scene, seen at grazing angles, nothing shared.
//! Deterministic: triangles come from a 64-bit integer generator (splitmix64) mapped to `f64`.

use crate::builder::{check_size, light, material, v3, view, SceneBuilder, SPD_BACKGROUND};
use crate::GenError;
use parrt_render::description::SceneDescription;
use parrt_render::vec3::Vec3d;

const NAME: &str = "soup";

/// Default size factor: 2,000 triangles.
pub const DEFAULT_SIZE: u32 = 2;

/// splitmix64: a uniform number in [0, 1) per call, the same on every machine.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// A unit vector (rejection from the cube).
    fn dir(&mut self) -> Vec3d {
        loop {
            let v = v3(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// Generates the soup at size factor `size` (1000·size triangles and a floor).
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    let count = check_size(NAME, size, u64::from(size).checked_mul(1000).map(|n| n + 1))?;
    let mut b = SceneBuilder::new(
        SPD_BACKGROUND,
        view(
            v3(2.6, -3.4, 1.9),
            v3(0.0, 0.0, -0.2),
            v3(0.0, 0.0, 1.0),
            45.0,
            0.01,
            512,
        ),
        vec![light(4.0, -3.0, 6.0), light(-5.0, -2.0, 3.0)],
        count,
    );
    b.material(material(0.8, 0.8, 0.7, 0.8, 0.1, 10.0, 0.0, 0.0));
    b.polygon(vec![
        v3(-3.0, -3.0, -1.2),
        v3(3.0, -3.0, -1.2),
        v3(3.0, 3.0, -1.2),
        v3(-3.0, 3.0, -1.2),
    ]);
    let colors = [
        material(0.9, 0.3, 0.2, 0.7, 0.3, 30.0, 0.0, 0.0),
        material(0.2, 0.8, 0.3, 0.8, 0.0, 0.0, 0.0, 0.0),
        material(0.3, 0.4, 0.9, 0.6, 0.4, 60.0, 0.0, 0.0),
    ];
    let mut rng = Rng(0x005e_ed50_u64 + u64::from(size));
    for k in 0..size as usize * 1000 {
        if k % 334 == 0 {
            b.material(colors[(k / 334) % 3].clone());
        }
        let c = v3(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let len = rng.range(0.05, 0.6);
        let u = rng.dir();
        // A second direction perpendicular to u.
        let w = u.cross(rng.dir()).normalize();
        let thin = len * 10f64.powf(rng.range(-4.0, -2.0));
        let (p0, p1, p2) = match k % 3 {
            // Needle: a short base of width `thin` at one end, the apex far away.
            0 => (c - w * (thin * 0.5), c + w * (thin * 0.5), c + u * len),
            // Cap: a long base with the apex barely off it.
            1 => (
                c,
                c + u * len,
                c + u * (len * rng.range(0.2, 0.8)) + w * thin,
            ),
            // Ordinary.
            _ => (c, c + u * len, c + w * (len * rng.range(0.3, 1.0))),
        };
        b.polygon(vec![p0, p1, p2]);
    }
    Ok(b.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_determinism() {
        let a = generate(1).unwrap();
        assert_eq!(a.primitives.len(), 1001);
        assert_eq!(a, generate(1).unwrap());
        assert!(generate(0).is_err());
    }

    #[test]
    fn slivers_are_too_thin_for_f32_by_the_estimate() {
        use parrt_render::settings::Precision;
        let c = parrt_render::precision::resolve(Precision::Auto, &generate(DEFAULT_SIZE).unwrap());
        // A needle's base edge, ~1e-5 units across at 3.4: its normal could turn by ~0.03 rad.
        assert_eq!(c.precision, Precision::F64, "{}", c.reason);
        assert!(c.reason.contains("edge"), "{}", c.reason);
    }
}

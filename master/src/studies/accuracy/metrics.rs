//! Image error metrics of the speed-against-error study (docs/design-measures.md, *Accuracy*). Both
//! images are the linear float films, each channel clamped to [0, 1] first (what an 8-bit output
//! could show); the metrics never look at the 8-bit PNG. Pure functions, no I/O. Both studies of
//! error use them: `bench accuracy` and `bench precision`.

use parrt_render::film::Rgb;

/// One image's error against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Root mean square error over every pixel and channel.
    pub rmse: f64,
    /// Peak signal-to-noise ratio in dB for peak 1: `20·log10(1 / rmse)` (infinite when equal).
    pub psnr: f64,
    /// Largest absolute difference of any channel of any pixel.
    pub max: f64,
    /// Share of pixels (0..=1) with some channel off by more than 1/255.
    pub off: f64,
}

/// The threshold of [`ImageError::off`]: one step of an 8-bit channel.
pub const ONE_STEP: f64 = 1.0 / 255.0;

/// A channel as the metrics see it: clamped to [0, 1], in f64 (so that the difference of two
/// channels is exact). NaN never reaches the film, but a metric must not propagate one: a NaN
/// channel counts as 0, the value the 8-bit output gives it, so it is an error wherever the
/// other image is not black there.
fn clamp01(v: f32) -> f64 {
    if v.is_nan() {
        0.0
    } else {
        (v as f64).clamp(0.0, 1.0)
    }
}

/// Compares `img` with `reference`, pixel by pixel, each channel as `clamp01` reads it (NaN
/// as 0). Panics if the sizes differ (the studies render both at the same size; a mismatch is
/// a bug, not bad input).
pub fn compare(img: &[Rgb], reference: &[Rgb]) -> ImageError {
    assert_eq!(img.len(), reference.len(), "images of different sizes");
    let mut sum_sq = 0.0;
    let mut max = 0.0f64;
    let mut off = 0usize;
    for (p, q) in img.iter().zip(reference) {
        let mut worst = 0.0f64;
        for c in 0..3 {
            let e = (clamp01(p[c]) - clamp01(q[c])).abs();
            sum_sq += e * e;
            worst = worst.max(e);
        }
        max = max.max(worst);
        if worst > ONE_STEP {
            off += 1;
        }
    }
    let n = img.len().max(1) as f64;
    let rmse = (sum_sq / (3.0 * n)).sqrt();
    ImageError {
        rmse,
        psnr: if rmse > 0.0 {
            20.0 * (1.0 / rmse).log10()
        } else {
            f64::INFINITY
        },
        max,
        off: off as f64 / n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_no_error() {
        let a = vec![[0.2, 0.5, 0.9]; 10];
        let e = compare(&a, &a);
        assert_eq!(e.rmse, 0.0);
        assert_eq!(e.max, 0.0);
        assert_eq!(e.off, 0.0);
        assert!(e.psnr.is_infinite());
    }

    #[test]
    fn known_values() {
        // One of four pixels off by 0.5 in one channel: mse = 0.25 / 12.
        let a = vec![[0.0, 0.0, 0.0]; 4];
        let mut b = a.clone();
        b[2][1] = 0.5;
        let e = compare(&a, &b);
        assert!((e.rmse - (0.25f64 / 12.0).sqrt()).abs() < 1e-12);
        assert!((e.psnr - 20.0 * (1.0 / e.rmse).log10()).abs() < 1e-12);
        assert_eq!(e.max, 0.5);
        assert_eq!(e.off, 0.25);
    }

    #[test]
    fn values_are_clamped_before_comparing() {
        // Overexposed pixels that both clamp to white do not differ; below one step is not "off".
        let a = vec![[3.0, -1.0, 0.5]];
        let b = vec![[1.5, 0.0, 0.5 + 0.9 / 255.0]];
        let e = compare(&a, &b);
        assert!(e.max < ONE_STEP && e.max > 0.0);
        assert_eq!(e.off, 0.0);
    }

    #[test]
    fn a_nan_channel_counts_as_black() {
        let a = vec![[f32::NAN, 0.0, 0.0], [f32::NAN, 0.0, 0.0]];
        let b = vec![[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]];
        let e = compare(&a, &b);
        assert_eq!(e.max, 0.5);
        assert_eq!(e.off, 0.5);
        assert!(e.rmse.is_finite());
    }
}

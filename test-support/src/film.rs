//! Films compared: bit for bit (one comparison for the library tests and the distributed tests),
//! or by how far apart their pixels are.

use parrt_render::film::Film;

/// Asserts two films are equal bit for bit (f32 bit patterns), naming the first difference.
pub fn assert_same_bits(a: &Film, b: &Film, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}: size");
    assert_eq!(a.pixels.len(), b.pixels.len(), "{what}: linear pixels held");
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let same = p.iter().zip(q).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(
            same,
            "{what}: pixel {} ({}, {}) differs: {p:?} vs {q:?}",
            i,
            i as u32 % a.width,
            i as u32 / a.width
        );
    }
    // A render that is all one colour would prove little.
    assert!(
        a.pixels.iter().any(|p| p != &a.pixels[0]),
        "{what}: flat image"
    );
}

/// Per-pixel differences of two films on the linear values clamped to [0, 1]: (mean absolute
/// difference per channel, share of pixels with some channel off by more than 1/255).
pub fn compare(a: &Film, b: &Film) -> (f64, f64) {
    let mut sum = 0.0;
    let mut off = 0usize;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let mut worst = 0.0f64;
        for c in 0..3 {
            let e = (p[c].clamp(0.0, 1.0) as f64 - q[c].clamp(0.0, 1.0) as f64).abs();
            sum += e;
            worst = worst.max(e);
        }
        if worst > 1.0 / 255.0 {
            off += 1;
        }
    }
    let n = a.pixels.len() as f64;
    (sum / (3.0 * n), off as f64 / n)
}

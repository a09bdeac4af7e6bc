//! Films compared bit for bit. Also compiled into `parrt_tests` (by path, from `tests/src/dist.rs`)
//! so the distributed tests and these use one comparison.

use parrt::film::Film;

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

//! Generator behaviour that does not need SPD's files: determinism, NFF output, the material
//! ordering invariant the writer relies on, refusal of bad sizes, and (ignored by default,
//! it takes seconds) the 2-million-triangle mountain at size 10.

use parrt_render::description::SceneDescription;
use parrt_scenes::{builder::MAX_PRIMITIVES, generate, generators, GenError};
use proptest::prelude::*;

fn check_invariants(name: &str, s: &SceneDescription) {
    assert!(!s.primitives.is_empty(), "{name}: no primitives");
    assert!(
        s.primitives.len() as u64 <= MAX_PRIMITIVES,
        "{name}: over the limit"
    );
    let mut last = 0;
    for p in &s.primitives {
        assert!(
            p.material >= last,
            "{name}: material indices must not decrease"
        );
        assert!(
            (p.material as usize) < s.materials.len(),
            "{name}: material out of range"
        );
        last = p.material;
        let b = p.shape.bounds();
        assert!(
            b.min.is_finite() && b.max.is_finite(),
            "{name}: non-finite coordinates"
        );
    }
    let v = &s.view;
    assert!(
        (v.at - v.from).length() > 0.0 && v.up.length() > 0.0,
        "{name}: degenerate camera"
    );
}

#[test]
fn default_scenes_are_deterministic_and_write_nff() {
    for g in generators() {
        let a = generate(g.name, None).unwrap();
        let b = generate(g.name, Some(g.default_size)).unwrap();
        assert!(a == b, "{}: two generations differ", g.name);
        check_invariants(g.name, &a);
        let text = parrt_render::nff::to_nff(&a);
        assert!(
            text.starts_with("b "),
            "{}: NFF starts with {:?}",
            g.name,
            &text[..10]
        );
        assert!(text.contains("\nv\nfrom "), "{}: no view block", g.name);
        assert_eq!(
            text,
            parrt_render::nff::to_nff(&b),
            "{}: NFF text differs",
            g.name
        );
    }
}

#[test]
fn generators_are_listed_in_alphabetical_order() {
    let names: Vec<&str> = generators().iter().map(|g| g.name).collect();
    let mut sorted = names.clone();
    sorted.sort_unstable();
    assert_eq!(names, sorted);
    assert_eq!(names.len(), 11);
}

#[test]
fn unknown_names_are_refused_with_the_list() {
    match generate("teapots", None) {
        Err(GenError::UnknownScene(n, known)) => {
            assert_eq!(n, "teapots");
            for g in generators() {
                assert!(known.contains(g.name));
            }
        }
        other => panic!("expected UnknownScene, got {other:?}"),
    }
}

#[test]
fn bad_sizes_are_refused_not_panicked() {
    for g in generators() {
        for size in [0, 1000, u32::MAX] {
            match generate(g.name, Some(size)) {
                Err(GenError::BadSize { name, size: s, why }) => {
                    assert_eq!((name.as_str(), s), (g.name, size));
                    assert!(!why.is_empty());
                }
                other => panic!(
                    "{} size {size}: expected BadSize, got {:?}",
                    g.name,
                    other.map(|s| s.primitives.len())
                ),
            }
        }
    }
    for (name, size) in [
        ("mount", 12),
        ("mount", 14),
        ("balls", 8),
        ("balls", 9),
        ("teapot", 1),
        ("tetra", 13),
    ] {
        assert!(
            matches!(generate(name, Some(size)), Err(GenError::BadSize { .. })),
            "{name} {size} should be refused"
        );
    }
}

/// Primitive count formulas from SPD's documentation.
fn expected_count(name: &str, n: u64) -> u64 {
    match name {
        "balls" => (0..=n).map(|k| 9u64.pow(k as u32)).sum::<u64>() + 1,
        "gears" => n * n * n * 146 + 1,
        "jacks" => (0..n).map(|k| 8u64.pow(k as u32)).sum::<u64>() * 9,
        "lattice" => (n + 1).pow(3) + 3 * n * (n + 1).pow(2),
        "mount" => 2 * 4u64.pow(n as u32) + 4,
        "rings" => 60 * (1..=n).map(|d| d * d).sum::<u64>() + 1,
        "shells" => 180 * 2u64.pow(n as u32) + 1,
        "sombrero" => {
            let side = 32 * 2u64.pow(n as u32 - 1);
            2 * (side - 1) * (side - 1)
        }
        "teapot" => 64 * n * n - 8 * n + n * n,
        "tetra" => 4u64.pow(n as u32),
        "tree" => 2 * (2u64.pow(n as u32 + 1) - 1) + 1,
        other => panic!("no formula for {other}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn small_sizes_follow_the_count_formulas(g in 0usize..11, size in 2u32..4) {
        let name = generators()[g].name;
        let s = generate(name, Some(size)).unwrap();
        check_invariants(name, &s);
        prop_assert_eq!(s.primitives.len() as u64, expected_count(name, u64::from(size)));
        prop_assert!(s == generate(name, Some(size)).unwrap());
    }
}

#[test]
#[ignore = "generates 2.1 million triangles (seconds); run with --ignored"]
fn mount_size_10_generates() {
    let s = generate("mount", Some(10)).unwrap();
    assert_eq!(s.primitives.len() as u64, 2 * 4u64.pow(10) + 4);
    check_invariants("mount-10", &s);
}

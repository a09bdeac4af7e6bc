//! The reader's numbers are exactly what `str::parse::<f64>` (correctly rounded) gives, for every
//! C `%g`-like spelling, including the forms its fast path takes and those it hands on.

use parrt_render::nff::number::parse_real;
use proptest::prelude::*;

/// Number spellings: sign, integer digits, optional point and fraction, optional exponent.
fn spelling() -> impl Strategy<Value = String> {
    (
        prop::sample::select(vec!["", "-", "+"]),
        "[0-9]{0,22}",
        prop::option::of("[0-9]{0,22}"),
        prop::option::of((prop::sample::select(vec!["e", "E", "e-", "e+"]), 0u32..400)),
    )
        .prop_filter_map("needs a digit", |(sign, int, frac, exp)| {
            let has_digit = !int.is_empty() || frac.as_ref().is_some_and(|f| !f.is_empty());
            if !has_digit {
                return None;
            }
            let mut s = format!("{sign}{int}");
            if let Some(f) = frac {
                s.push('.');
                s.push_str(&f);
            }
            if let Some((e, n)) = exp {
                s.push_str(&format!("{e}{n}"));
            }
            Some(s)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn agrees_with_std_bit_for_bit(s in spelling()) {
        let std = s.parse::<f64>().expect("a valid spelling");
        match parse_real(s.as_bytes()) {
            Ok(v) => prop_assert_eq!(v.to_bits(), std.to_bits(), "{}", s),
            Err(_) => prop_assert!(!std.is_finite(), "{} refused but std reads {}", s, std),
        }
    }

    #[test]
    fn shortest_printing_reads_back(bits in any::<u64>()) {
        let v = f64::from_bits(bits);
        prop_assume!(v.is_finite());
        for s in [format!("{v}"), format!("{v:e}"), format!("{v:?}")] {
            prop_assert_eq!(parse_real(s.as_bytes()).map(f64::to_bits), Ok(bits), "{}", s);
        }
    }
}

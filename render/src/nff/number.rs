//! Number tokens: C `%g`-style reals, correctly rounded, and whole-number counts. Pure functions
//! from bytes to values; they say what is wrong, never where (the parser adds the location).
//! And the way back for the writers (`write_real`): the shortest text that reads as the same
//! `f64`.
//!
//! Reals: an optional sign, digits with an optional `.` (`1`, `.5`, `5.`), and an optional
//! exponent (`1e-3`, `2E+5`). The common case — at most 19 significant digits and a small decimal
//! exponent — is computed exactly (Clinger's fast path: an exact integer times or divided by an
//! exact power of ten, one correctly rounded IEEE operation); everything else goes to
//! `str::parse::<f64>`, which is also correctly rounded. NaN, infinities and overflow are refused.

/// Why a token is not an acceptable real number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RealError {
    /// Not a number at all (`x`, `1.2.3`, `1e`).
    Invalid,
    /// A NaN or infinity literal (`nan`, `inf`, `Infinity`).
    NotFinite,
    /// A valid literal too large for an `f64` (`1e999`).
    Overflow,
}

/// Why a token is not an acceptable whole number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CountError {
    /// Not made of decimal digits only.
    Invalid,
    /// More than `u64::MAX`.
    TooLarge,
}

/// Exact powers of ten representable in an `f64` (10^0 ..= 10^22).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Largest integer below which every integer is exact in an `f64`.
const MAX_EXACT: u64 = 1 << 53;

/// Parses a real number token, correctly rounded; refuses NaN, infinities and overflow.
#[inline]
pub fn parse_real(tok: &[u8]) -> Result<f64, RealError> {
    match fast_prefix(tok, 0) {
        Some((v, end)) if end == tok.len() => Ok(v),
        _ => slow_path(tok),
    }
}

/// An optional `-` or `+` at `s[i]`: whether it is `-`, and the offset just past it.
#[inline(always)]
fn sign(s: &[u8], i: usize) -> (bool, usize) {
    match s.get(i) {
        Some(b'-') => (true, i + 1),
        Some(b'+') => (false, i + 1),
        _ => (false, i),
    }
}

/// The decimal digits from `s[i]` on appended to `acc` (`acc·10 + d` per digit, wrapping: the
/// callers refuse lengths whose value could wrap): the new value and the offset past the last
/// digit.
#[inline(always)]
fn digits(s: &[u8], mut i: usize, mut acc: u64) -> (u64, usize) {
    while let Some(&b) = s.get(i) {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        acc = acc.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    (acc, i)
}

/// The exact fast path over the number that starts at `src[start]`: its value and the offset
/// just past it. `None` when the number is unusual (more than 19 digits, counting leading zeros;
/// a decimal exponent beyond ±22; a mantissa of 2^53 or more) or there is no number there. The
/// caller checks that the number ends where the token ends; if not, the token is not this number.
#[inline(always)]
pub fn fast_prefix(src: &[u8], start: usize) -> Option<(f64, usize)> {
    let s = src.get(start..)?;
    let (neg, mut i) = sign(s, 0);
    // Up to 19 decimal digits fit in a u64; more make the token go to the general path, so the
    // wrapping arithmetic below never produces a value that is used.
    let int_start = i;
    let mut mantissa;
    (mantissa, i) = digits(s, i, 0);
    let mut ndigits = i - int_start;
    let mut exp10: i64 = 0;
    if s.get(i) == Some(&b'.') {
        i += 1;
        let frac_start = i;
        (mantissa, i) = digits(s, i, mantissa);
        ndigits += i - frac_start;
        exp10 = -((i - frac_start) as i64);
    }
    if ndigits == 0 || ndigits > 19 {
        return None;
    }
    if let Some(b'e' | b'E') = s.get(i) {
        let (eneg, exp_start) = sign(s, i + 1);
        let e;
        (e, i) = digits(s, exp_start, 0);
        if i == exp_start || i - exp_start > 6 {
            return None;
        }
        // At most 6 digits, so the value fits an `i64` exactly.
        let e = e as i64;
        exp10 += if eneg { -e } else { e };
    }
    if mantissa >= MAX_EXACT {
        return None;
    }
    let m = mantissa as f64; // exact: mantissa < 2^53
    let v = if mantissa == 0 {
        0.0
    } else if (0..=22).contains(&exp10) {
        m * POW10[exp10 as usize]
    } else if (-22..0).contains(&exp10) {
        m / POW10[(-exp10) as usize]
    } else {
        return None;
    };
    // Both factors are exact and below 2^53 · 10^22, so the product is finite.
    Some((if neg { -v } else { v }, start + i))
}

/// The general path: validates the C-style grammar, then `str::parse::<f64>`.
#[cold]
fn slow_path(tok: &[u8]) -> Result<f64, RealError> {
    let numeric = !tok.is_empty()
        && tok
            .iter()
            .all(|b| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-'));
    if !numeric {
        return Err(if is_non_finite_word(tok) {
            RealError::NotFinite
        } else {
            RealError::Invalid
        });
    }
    // Only ASCII bytes remain, so this cannot fail; treat a failure as invalid anyway.
    let s = std::str::from_utf8(tok).map_err(|_| RealError::Invalid)?;
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(RealError::Overflow),
        Err(_) => Err(RealError::Invalid),
    }
}

/// True for the spellings of NaN and infinity that C and Rust accept, with an optional sign.
fn is_non_finite_word(tok: &[u8]) -> bool {
    let t = match tok.first() {
        Some(b'+' | b'-') => &tok[1..],
        _ => tok,
    };
    ["nan", "inf", "infinity"]
        .iter()
        .any(|w| t.eq_ignore_ascii_case(w.as_bytes()))
}

/// True when the token starts like a number (sign, digit or point): used to decide whether an
/// optional group of numbers follows. Entity keywords start with a letter, so this is unambiguous.
#[inline]
pub fn looks_numeric(tok: &[u8]) -> bool {
    matches!(tok.first(), Some(b'0'..=b'9' | b'+' | b'-' | b'.'))
}

/// Parses a whole number made of decimal digits only (no sign, point or exponent).
#[inline]
pub fn parse_count(tok: &[u8]) -> Result<u64, CountError> {
    if tok.is_empty() || !tok.iter().all(u8::is_ascii_digit) {
        return Err(CountError::Invalid);
    }
    let mut n: u64 = 0;
    for &b in tok {
        n = n
            .checked_mul(10)
            .and_then(|n| n.checked_add(u64::from(b - b'0')))
            .ok_or(CountError::TooLarge)?;
    }
    Ok(n)
}

/// Writes `v` in the shortest form that reads back as the same `f64` (Rust's shortest
/// round-trip digits; exponent notation outside 1e-4..1e15), for the NFF and POV-Ray writers.
pub(crate) fn write_real(out: &mut String, v: f64) {
    use std::fmt::Write;
    let a = v.abs();
    if a != 0.0 && !(1e-4..1e15).contains(&a) {
        let _ = write!(out, "{v:e}");
    } else {
        let _ = write!(out, "{v}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(s: &str) -> Result<f64, RealError> {
        parse_real(s.as_bytes())
    }

    #[test]
    fn c_g_forms() {
        assert_eq!(r("1"), Ok(1.0));
        assert_eq!(r("-0.5"), Ok(-0.5));
        assert_eq!(r(".5"), Ok(0.5));
        assert_eq!(r("5."), Ok(5.0));
        assert_eq!(r("+1"), Ok(1.0));
        assert_eq!(r("1e-3"), Ok(1e-3));
        assert_eq!(r("1E+3"), Ok(1e3));
        assert_eq!(r("-2.55836e-17"), Ok(-2.55836e-17));
        assert_eq!(r("100000"), Ok(100000.0));
        let z = r("-0").unwrap();
        assert!(z == 0.0 && z.is_sign_negative());
        let z = r("-0.0e5").unwrap();
        assert!(z == 0.0 && z.is_sign_negative());
    }

    #[test]
    fn agrees_with_std_on_awkward_values() {
        for s in [
            "0.1",
            "0.3",
            "123456789012345678",
            "1234567890123456789012",
            "9007199254740993",
            "1e22",
            "1e23",
            "4.9e-324",
            "2.2250738585072014e-308",
            "1.7976931348623157e308",
            "0.000000000000000000000000001",
            "-0.966025",
            "1e-999",
        ] {
            assert_eq!(
                r(s).map(f64::to_bits),
                Ok(s.parse::<f64>().unwrap().to_bits()),
                "{s}"
            );
        }
    }

    #[test]
    fn refusals() {
        for s in [
            "x", "1.2.3", "1e", "e5", ".", "-", "1-", "--1", "1e5.0", "", "0x10",
        ] {
            assert_eq!(r(s), Err(RealError::Invalid), "{s}");
        }
        for s in ["nan", "NaN", "inf", "-inf", "+Infinity"] {
            assert_eq!(r(s), Err(RealError::NotFinite), "{s}");
        }
        assert_eq!(r("1e999"), Err(RealError::Overflow));
        assert_eq!(r("-1e400"), Err(RealError::Overflow));
    }

    #[test]
    fn counts() {
        assert_eq!(parse_count(b"512"), Ok(512));
        assert_eq!(parse_count(b"0"), Ok(0));
        assert_eq!(parse_count(b"18446744073709551615"), Ok(u64::MAX));
        assert_eq!(
            parse_count(b"18446744073709551616"),
            Err(CountError::TooLarge)
        );
        for s in ["-1", "+1", "1.0", "1e3", "", "x"] {
            assert_eq!(parse_count(s.as_bytes()), Err(CountError::Invalid), "{s}");
        }
    }

    #[test]
    fn looks_numeric_tells_numbers_from_keywords() {
        assert!(looks_numeric(b"1"));
        assert!(looks_numeric(b"-x"));
        assert!(looks_numeric(b".5"));
        assert!(!looks_numeric(b"f"));
        assert!(!looks_numeric(b"nan"));
    }
}

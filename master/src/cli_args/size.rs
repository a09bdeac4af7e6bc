//! Image sizes given as one flag (`--size WxH` of the accuracy and precision studies): both
//! sides whole numbers of at least 1, else bad input (exit 2) naming the flag.

use super::ArgError;

/// Parses `WxH` (both at least 1).
pub fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let bad = || ArgError::Value(format!("--size {s}: expected WxH, e.g. 256x256"));
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 {
        return Err(bad().into());
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_bad_ones_are_rejected() {
        assert_eq!(parse_size("256x128").ok(), Some((256, 128)));
        assert_eq!(parse_size("64X64").ok(), Some((64, 64)));
        for bad in ["", "256", "0x4", "ax4", "4x-1"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}

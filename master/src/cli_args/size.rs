//! `--size`, which means one thing on every command that takes it: an image's size in pixels,
//! `WxH` (e.g. `1024x768`) or `N` for `N`×`N`. Both sides whole numbers of at least 1, else bad
//! input (exit 2) naming the flag. (A generated scene's size factor is another thing:
//! `parrt scene --factor N`, or `NAME:N` where a scene is named.)

use super::ArgError;

/// Parses `WxH`, or `N` for `N`×`N` (each side at least 1).
pub fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let bad = || {
        ArgError::Value(format!(
            "--size {s}: expected WxH or N (pixels), e.g. 256x256"
        ))
    };
    let side = |t: &str| match t.trim().parse::<u32>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(bad()),
    };
    match s.split_once(['x', 'X']) {
        Some((w, h)) => Ok((side(w)?, side(h)?)),
        None => {
            let n = side(s)?;
            Ok((n, n))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_bad_ones_are_rejected() {
        assert_eq!(parse_size("256x128").ok(), Some((256, 128)));
        assert_eq!(parse_size("64X64").ok(), Some((64, 64)));
        assert_eq!(parse_size("256").ok(), Some((256, 256)));
        for bad in ["", "0", "0x4", "ax4", "4x-1", "4x", "x4", "4x4x4"] {
            let e = parse_size(bad).expect_err(bad);
            assert_eq!(
                e.to_string(),
                format!("--size {bad}: expected WxH or N (pixels), e.g. 256x256")
            );
        }
    }
}

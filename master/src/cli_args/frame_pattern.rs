//! The output of a sequence (`-o out/frame-%04d.png`): a path whose file name holds exactly one
//! printf-like frame number field, `%d` or `%0Nd` (zero-padded to N digits; the frame number
//! counts from 0), with `%%` for a literal `%`. A pattern with no field names one file, which
//! is only allowed for a sequence of one frame; two fields, any other `%` and a field in a
//! folder's name are refused (bad input, exit 2). A single-frame render never reads its `-o`
//! as a pattern.

use super::ArgError;
use std::path::{Path, PathBuf};

/// A parsed output pattern.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FramePattern {
    /// The folder part, used as given.
    dir: PathBuf,
    /// The file name before the field (with `%%` already made `%`).
    before: String,
    /// The file name after the field, or the whole name when there is no field.
    after: String,
    /// Digits to pad the number to (0: none); `None` when the name has no field.
    field: Option<usize>,
}

impl FramePattern {
    /// Parses `-o` as the pattern of a sequence of `frames` frames.
    pub fn parse(path: &Path, frames: usize) -> Result<Self, ArgError> {
        let shown = path.display();
        let name = path
            .file_name()
            .ok_or_else(|| ArgError::Value(format!("-o {shown}: names no file")))?
            .to_str()
            .ok_or_else(|| ArgError::Value(format!("-o {shown}: the name is not UTF-8")))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        if dir.to_string_lossy().contains('%') {
            return Err(ArgError::Value(format!(
                "-o {shown}: a % in a folder's name; the frame number (%d or %04d) goes in the \
                 file name"
            )));
        }
        let (mut before, mut after) = (String::new(), String::new());
        let mut field: Option<usize> = None;
        let mut fields = 0;
        let mut chars = name.chars().peekable();
        while let Some(c) = chars.next() {
            let text = if field.is_some() {
                &mut after
            } else {
                &mut before
            };
            if c != '%' {
                text.push(c);
                continue;
            }
            if chars.peek() == Some(&'%') {
                chars.next();
                text.push('%');
                continue;
            }
            let mut digits = String::new();
            while let Some(d) = chars.peek().copied().filter(char::is_ascii_digit) {
                digits.push(d);
                chars.next();
            }
            let width = match (chars.next(), digits.as_str()) {
                (Some('d'), "") => 0,
                (Some('d'), d) if d.starts_with('0') && d.len() > 1 => d[1..]
                    .parse::<usize>()
                    .ok()
                    .filter(|w| *w <= 20)
                    .ok_or_else(|| {
                        ArgError::Value(format!("-o {shown}: %{d}d pads to too many digits"))
                    })?,
                _ => {
                    return Err(ArgError::Value(format!(
                        "-o {shown}: a % that is not a frame number field; use %d or %0Nd \
                         (e.g. %04d) for the frame number and %% for a literal %"
                    )))
                }
            };
            fields += 1;
            if field.is_none() {
                field = Some(width);
            }
        }
        if fields > 1 {
            return Err(ArgError::Value(format!(
                "-o {shown}: {fields} frame number fields; give exactly one (%d or %04d)"
            )));
        }
        if field.is_none() {
            after = std::mem::take(&mut before);
            if frames > 1 {
                return Err(ArgError::Value(format!(
                    "-o {shown}: no frame number field (%d or %04d) for a sequence of {frames} \
                     frames: they would all be written to one file"
                )));
            }
        }
        Ok(FramePattern {
            dir,
            before,
            after,
            field,
        })
    }

    /// The output of frame `k`.
    pub fn path(&self, k: usize) -> PathBuf {
        let name = match self.field {
            Some(w) => format!("{}{k:0w$}{}", self.before, self.after),
            None => self.after.clone(),
        };
        self.dir.join(name)
    }

    /// The folder the frames go to (empty: the current one).
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str, frames: usize) -> Result<FramePattern, String> {
        FramePattern::parse(Path::new(s), frames).map_err(|e| e.to_string())
    }

    #[test]
    fn fields_pad_and_percent_signs_stay() {
        let p = parse("out/frame-%04d.png", 24).unwrap();
        assert_eq!(p.path(7), Path::new("out/frame-0007.png"));
        assert_eq!(p.path(12345), Path::new("out/frame-12345.png"));
        assert_eq!(p.dir(), Path::new("out"));
        let p = parse("f%d-100%%.png", 3).unwrap();
        assert_eq!(p.path(2), Path::new("f2-100%.png"));
        let one = parse("only.png", 1).unwrap();
        assert_eq!(one.path(0), Path::new("only.png"));
        assert_eq!(parse("a%%.png", 1).unwrap().path(0), Path::new("a%.png"));
    }

    #[test]
    fn bad_patterns_say_why() {
        let e = parse("out.png", 2).unwrap_err();
        assert!(e.contains("no frame number field"), "{e}");
        let e = parse("a%d-%04d.png", 2).unwrap_err();
        assert!(e.contains("2 frame number fields"), "{e}");
        for bad in ["a%s.png", "a%4d.png", "a%.png", "a%0d.png"] {
            let e = parse(bad, 2).unwrap_err();
            assert!(e.contains("not a frame number field"), "{bad}: {e}");
        }
        let e = parse("o%d/f%d.png", 2).unwrap_err();
        assert!(e.contains("folder"), "{e}");
    }
}

//! The flags that make a render a sequence of frames (`parrt render`): the frames listed in a
//! file (`--frames-from LIST`), or one scene and a camera path (`--orbit DEGREES --frames N`),
//! and the window of frames in flight (`--window W`). Several scene files on the command line
//! make a sequence too (the positional argument). Reading a LIST is here; its errors name the
//! LIST and the line (bad input, exit 2).

use super::ArgError;
use clap::Args;
use std::path::{Path, PathBuf};

/// Sequence flags, flattened into `parrt render`.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Sequences (several scene files, --frames-from or --orbit)")]
pub struct SequenceArgs {
    /// Render the scenes listed in LIST as a sequence, frame k from line k: one NFF (or .json)
    /// file a line, relative to LIST's folder; blank lines and lines starting with # skipped.
    /// With a sequence, -o is a pattern with one %d or %0Nd frame number field (frames count
    /// from 0; %% is a literal %), e.g. -o out/frame-%04d.png; its folder is created if missing.
    #[arg(long, value_name = "LIST")]
    pub frames_from: Option<PathBuf>,
    /// Turn the eye about the look-at point, around the up vector, by DEGREES over the
    /// --frames N frames: frame k is turned by k·DEGREES/N, so frame 0 is the scene's own view
    /// (needs --frames).
    #[arg(long, value_name = "DEGREES", allow_negative_numbers = true)]
    pub orbit: Option<f64>,
    /// With --orbit: the number of frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// Most frames alive at once (opened, rendering or being written): the threads fill one
    /// frame's tail with the next frame's tiles; the images take at most W × width × height ×
    /// 3 bytes (12 with an EXR output). Default 2; a sequence's flag only (refused for a render of one frame).
    #[arg(long, value_name = "W")]
    pub window: Option<usize>,
}

/// The sequence flags of `parrt master`, whose `--window` is already a worker's window of
/// tiles in flight: the frames, and the window of frames as `--frames-window`.
#[derive(Debug, Clone, Args)]
#[command(next_help_heading = "Sequences (several scene files, --frames-from or --orbit)")]
pub struct FrameArgs {
    /// Render the scenes listed in LIST as a sequence, frame k from line k (as `parrt render
    /// --frames-from`); -o is then a pattern with one %d or %0Nd frame number field.
    #[arg(long, value_name = "LIST")]
    pub frames_from: Option<PathBuf>,
    /// Turn the eye about the look-at point by DEGREES over the --frames N frames (as `parrt
    /// render --orbit`).
    #[arg(long, value_name = "DEGREES", allow_negative_numbers = true)]
    pub orbit: Option<f64>,
    /// With --orbit: the number of frames.
    #[arg(long, value_name = "N")]
    pub frames: Option<usize>,
    /// Most frames open at once on the workers (as `parrt render --window` of a sequence): the
    /// next frame's tiles fill one frame's tail; each worker holds a built scene per frame
    /// open. Default 2 (at most 16, what a worker holds); a sequence's flag only.
    #[arg(long, value_name = "W")]
    pub frames_window: Option<usize>,
}

impl FrameArgs {
    /// The same flags as [`SequenceArgs`] (`--frames-window` as its window).
    pub fn sequence(&self) -> SequenceArgs {
        SequenceArgs {
            frames_from: self.frames_from.clone(),
            orbit: self.orbit,
            frames: self.frames,
            window: self.frames_window,
        }
    }

    /// Refuses `--frames-window` below 1, or given for a render of one frame (`sequence`:
    /// whether this is a sequence).
    pub fn check(&self, sequence: bool) -> Result<(), ArgError> {
        match self.frames_window {
            Some(0) => Err(ArgError::Value("--frames-window must be at least 1".into())),
            Some(_) if !sequence => Err(ArgError::Conflict(
                "--frames-window is a sequence's flag (several scene files, --frames-from or \
                 --orbit); a render of one frame has no frames to overlap"
                    .into(),
            )),
            _ => Ok(()),
        }
    }
}

/// Frames alive at once when `--window` is not given: one frame's tail filled by the next.
pub const DEFAULT_WINDOW: usize = 2;

impl SequenceArgs {
    /// Whether these flags ask for a sequence (besides several scene files).
    pub fn asked(&self) -> bool {
        self.frames_from.is_some() || self.orbit.is_some() || self.frames.is_some()
    }

    /// The window of frames in flight (`--window`, else [`DEFAULT_WINDOW`]).
    pub fn window(&self) -> usize {
        self.window.unwrap_or(DEFAULT_WINDOW)
    }
}

/// One frame's scene file named by a LIST: its path (resolved against LIST's folder) and the
/// line that named it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ListedFrame {
    /// The scene file.
    pub path: PathBuf,
    /// Its line in LIST (from 1).
    pub line: usize,
}

/// Reads LIST (at most `max_bytes`): one path a line, relative to LIST's folder unless
/// absolute; blank lines and lines whose first non-blank character is `#` skipped.
pub fn read_frame_list(list: &Path, max_bytes: u64) -> anyhow::Result<Vec<ListedFrame>> {
    let bytes = super::limits::read_path(list, max_bytes)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count();
        ArgError::Value(format!("{}:{line}: not UTF-8 text", list.display()))
    })?;
    let dir = list.parent().unwrap_or(Path::new(""));
    let frames: Vec<ListedFrame> = text
        .lines()
        .enumerate()
        .filter_map(|(i, l)| {
            let l = l.trim();
            (!l.is_empty() && !l.starts_with('#')).then(|| ListedFrame {
                path: dir.join(l),
                line: i + 1,
            })
        })
        .collect();
    if frames.is_empty() {
        return Err(ArgError::Value(format!(
            "{}: names no frames (one scene file a line)",
            list.display()
        ))
        .into());
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_relative_to_the_list_and_comments_are_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let list = dir.path().join("frames.txt");
        std::fs::write(&list, "# frames\n\na.nff\n  sub/b.nff  \n/abs/c.nff\n").unwrap();
        let got = read_frame_list(&list, 1 << 20).unwrap();
        let want = [
            (dir.path().join("a.nff"), 3),
            (dir.path().join("sub/b.nff"), 4),
            (PathBuf::from("/abs/c.nff"), 5),
        ];
        assert_eq!(got.len(), 3);
        for (g, (p, l)) in got.iter().zip(want) {
            assert_eq!((&g.path, g.line), (&p, l));
        }
        std::fs::write(&list, "# nothing\n").unwrap();
        let e = read_frame_list(&list, 1 << 20).unwrap_err().to_string();
        assert!(
            e.ends_with("frames.txt: names no frames (one scene file a line)"),
            "{e}"
        );
        std::fs::write(&list, b"a.nff\n\xff.nff\n").unwrap();
        let e = read_frame_list(&list, 1 << 20).unwrap_err().to_string();
        assert!(e.ends_with("frames.txt:2: not UTF-8 text"), "{e}");
    }
}

//! The NFF tokenizer: splits bytes into whitespace-separated tokens and tracks each token's line
//! and column. It knows nothing about entities and never allocates.
//!
//! Every run of space, tab, CR, LF and form feed is one separator; `#` starts a comment that runs
//! to the end of the line (also in the middle of a token, which it ends). Lines and columns are
//! 1-based; a column counts bytes from the start of the line (a tab counts as one).

use super::number;

/// A token: a byte range of the source and where it starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Token {
    /// Byte offset of the first byte.
    pub start: usize,
    /// Byte offset one past the last byte.
    pub end: usize,
    /// 1-based line of the first byte.
    pub line: u32,
    /// 1-based byte column of the first byte.
    pub column: u32,
}

/// A position in the source (1-based line and column), used for errors that have no token,
/// such as the end of the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Position {
    /// 1-based line.
    pub line: u32,
    /// 1-based byte column.
    pub column: u32,
}

impl Token {
    /// Where the token starts.
    pub fn position(&self) -> Position {
        Position {
            line: self.line,
            column: self.column,
        }
    }
}

/// Byte classes: 0 token byte, 1 separator, 2 newline (a separator that starts a line),
/// 3 comment start.
const fn classes() -> [u8; 256] {
    let mut t = [0u8; 256];
    t[b' ' as usize] = 1;
    t[b'\t' as usize] = 1;
    t[b'\r' as usize] = 1;
    t[0x0c] = 1;
    t[b'\n' as usize] = 2;
    t[b'#' as usize] = 3;
    t
}

static CLASS: [u8; 256] = classes();

const TOKEN: u8 = 0;
const NEWLINE: u8 = 2;
const COMMENT: u8 = 3;

/// A cursor over NFF bytes yielding [`Token`]s, with one token of look-ahead.
#[derive(Clone, Debug)]
pub struct Lexer<'a> {
    src: &'a [u8],
    pos: usize,
    line: u32,
    line_start: usize,
    peeked: Option<Token>,
}

impl<'a> Lexer<'a> {
    /// A lexer at the start of `src`.
    pub fn new(src: &'a [u8]) -> Self {
        Lexer {
            src,
            pos: 0,
            line: 1,
            line_start: 0,
            peeked: None,
        }
    }

    /// The source bytes.
    #[inline]
    pub fn src(&self) -> &'a [u8] {
        self.src
    }

    /// The bytes of `t`.
    #[inline]
    pub fn text(&self, t: &Token) -> &'a [u8] {
        &self.src[t.start..t.end]
    }

    /// Bytes after the end of `t` (an upper bound on what the rest of the file can hold).
    #[inline]
    pub fn remaining_after(&self, t: &Token) -> usize {
        self.src.len() - t.end
    }

    /// The position just after the last byte of the file (where "end of file" errors point).
    pub fn end_position(&self) -> Position {
        // Counts the newlines the scan has not passed yet (none once it has hit the end).
        let mut line = self.line;
        let mut line_start = self.line_start;
        for (i, &b) in self.src.iter().enumerate().skip(self.pos) {
            if b == b'\n' {
                line += 1;
                line_start = i + 1;
            }
        }
        Position {
            line,
            column: col(self.src.len() - line_start),
        }
    }

    /// The next token without consuming it.
    #[inline]
    pub fn peek(&mut self) -> Option<Token> {
        if self.peeked.is_none() {
            self.peeked = self.scan();
        }
        self.peeked
    }

    /// The next token, consumed.
    #[inline]
    #[allow(clippy::should_implement_trait)] // not an Iterator: it has look-ahead and positions
    pub fn next(&mut self) -> Option<Token> {
        match self.peeked.take() {
            Some(t) => Some(t),
            None => self.scan(),
        }
    }

    /// The next token, consumed, and its value when it is a plain number that the exact fast
    /// path of [`number::fast_prefix`] reads (one pass over the bytes: the hot path of the
    /// reader). `None` as the value means "look at the token's text" — it may still be a number.
    #[inline]
    pub fn next_number(&mut self) -> Option<(Token, Option<f64>)> {
        if self.peeked.is_some() {
            return self.peeked.take().map(|t| (t, None));
        }
        let start = self.skip_separators()?;
        let src = self.src;
        if let Some((v, end)) = number::fast_prefix(src, start) {
            if src.get(end).is_none_or(|&b| CLASS[b as usize] != TOKEN) {
                self.pos = end;
                return Some((self.token(start, end), Some(v)));
            }
        }
        self.scan().map(|t| (t, None))
    }

    /// A token from `start` to `end` on the current line.
    #[inline]
    fn token(&self, start: usize, end: usize) -> Token {
        Token {
            start,
            end,
            line: self.line,
            column: col(start - self.line_start),
        }
    }

    /// Skips separators and comments; returns the offset of the next token's first byte.
    #[inline]
    fn skip_separators(&mut self) -> Option<usize> {
        let src = self.src;
        let mut i = self.pos;
        loop {
            let Some(&b) = src.get(i) else {
                self.pos = i;
                return None;
            };
            match CLASS[b as usize] {
                TOKEN => break,
                NEWLINE => {
                    i += 1;
                    self.line += 1;
                    self.line_start = i;
                }
                COMMENT => {
                    // To the end of the line; the newline itself is handled above.
                    while i < src.len() && src[i] != b'\n' {
                        i += 1;
                    }
                }
                _ => i += 1,
            }
        }
        self.pos = i;
        Some(i)
    }

    /// Skips separators and comments, then reads one token.
    #[inline]
    fn scan(&mut self) -> Option<Token> {
        let start = self.skip_separators()?;
        let src = self.src;
        let mut i = start;
        while i < src.len() && CLASS[src[i] as usize] == TOKEN {
            i += 1;
        }
        self.pos = i;
        Some(self.token(start, i))
    }
}

/// A 0-based byte offset within a line as a 1-based column, saturating on absurd line lengths.
#[inline]
fn col(offset: usize) -> u32 {
    u32::try_from(offset + 1).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tokens(s: &str) -> Vec<(String, u32, u32)> {
        let mut lx = Lexer::new(s.as_bytes());
        let mut out = Vec::new();
        while let Some(t) = lx.next() {
            out.push((
                String::from_utf8_lossy(lx.text(&t)).into_owned(),
                t.line,
                t.column,
            ));
        }
        out
    }

    #[test]
    fn whitespace_kinds_are_alike() {
        let t = tokens("a\tb\r\nc \x0c d\n\n  e");
        let names: Vec<_> = t.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(names, ["a", "b", "c", "d", "e"]);
        assert_eq!((t[2].1, t[2].2), (2, 1));
        assert_eq!((t[3].1, t[3].2), (2, 5));
        assert_eq!((t[4].1, t[4].2), (4, 3));
    }

    #[test]
    fn comments_run_to_end_of_line_and_end_tokens() {
        let t = tokens("# header\ns 1#x y\n  # z\n2");
        let names: Vec<_> = t.iter().map(|x| x.0.as_str()).collect();
        assert_eq!(names, ["s", "1", "2"]);
        assert_eq!((t[2].1, t[2].2), (4, 1));
    }

    #[test]
    fn peek_does_not_consume() {
        let mut lx = Lexer::new(b"x y");
        let p = lx.peek();
        assert_eq!(lx.next(), p);
        let y = lx.next().unwrap();
        assert_eq!(lx.text(&y), b"y");
        assert_eq!(lx.next(), None);
        assert_eq!(lx.peek(), None);
    }

    #[test]
    fn next_number_reads_plain_numbers_in_one_pass_and_defers_the_rest() {
        let mut lx = Lexer::new(b" 1.5\n-2e3#c\n1e999 x 5x 1.2.3 +.5");
        let mut got = Vec::new();
        while let Some((t, v)) = lx.next_number() {
            got.push((
                String::from_utf8_lossy(lx.text(&t)).into_owned(),
                v,
                t.line,
                t.column,
            ));
        }
        let want = [
            ("1.5", Some(1.5), 1, 2),
            ("-2e3", Some(-2000.0), 2, 1),
            ("1e999", None, 3, 1),
            ("x", None, 3, 7),
            ("5x", None, 3, 9),
            ("1.2.3", None, 3, 12),
            ("+.5", Some(0.5), 3, 18),
        ];
        let want: Vec<_> = want
            .iter()
            .map(|w| (w.0.to_string(), w.1, w.2, w.3))
            .collect();
        assert_eq!(got, want);
    }

    #[test]
    fn end_position_points_past_the_last_byte() {
        let mut lx = Lexer::new(b"ab\ncd");
        while lx.next().is_some() {}
        assert_eq!(lx.end_position(), Position { line: 2, column: 3 });
        let mut lx = Lexer::new(b"ab\n");
        while lx.next().is_some() {}
        assert_eq!(lx.end_position(), Position { line: 2, column: 1 });
    }
}

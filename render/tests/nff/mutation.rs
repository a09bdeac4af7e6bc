//! Robustness: small SPD files with random byte and token damage never make the reader panic.
//! Whatever it accepts must round-trip, and whatever it refuses must point inside the file.

use crate::support;

use parrt_render::nff::{self, Limits, NffErrorKind};
use proptest::prelude::*;
use std::sync::OnceLock;

/// Small SPD scenes (the README's "small" sizes and jacks-1), loaded once.
fn sources() -> &'static [Vec<u8>] {
    static SRC: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    SRC.get_or_init(|| {
        [
            "jacks-1.nff",
            "tetra-4.nff",
            "tree-6.nff",
            "rings-2.nff",
            "shells-1.nff",
            "gears-1.nff",
            "teapot-2.nff",
        ]
        .iter()
        .map(|n| support::spd_bytes(n))
        .collect()
    })
}

/// Tokens worth splicing in: keywords, counts, edge-case numbers, junk.
const TOKENS: &[&str] = &[
    "p",
    "pp",
    "s",
    "c",
    "f",
    "l",
    "b",
    "v",
    "from",
    "at",
    "up",
    "angle",
    "hither",
    "resolution",
    "nff",
    "#",
    "0",
    "-0",
    "1",
    "3",
    "2",
    "4000000000",
    "18446744073709551616",
    "nan",
    "inf",
    "1e999",
    "-1e-999",
    ".",
    "1.2.3",
    "+",
    "e5",
    "\u{e9}",
    "\n",
    "\t",
    "",
];

/// Interesting single bytes.
const BYTES: &[u8] = b"0123456789-+.eE \n\r\t#psclfbv\x00\xff";

#[derive(Clone, Debug)]
enum Mutation {
    DeleteByte(usize),
    InsertByte(usize, u8),
    ReplaceByte(usize, u8),
    DeleteToken(usize),
    ReplaceToken(usize, usize),
    InsertToken(usize, usize),
    DuplicateToken(usize),
    Truncate(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let pos = any::<usize>();
    let byte = prop_oneof![prop::sample::select(BYTES), any::<u8>()];
    let tok = 0..TOKENS.len();
    prop_oneof![
        pos.prop_map(Mutation::DeleteByte),
        (pos, byte.clone()).prop_map(|(p, b)| Mutation::InsertByte(p, b)),
        (pos, byte).prop_map(|(p, b)| Mutation::ReplaceByte(p, b)),
        pos.prop_map(Mutation::DeleteToken),
        (pos, tok.clone()).prop_map(|(p, t)| Mutation::ReplaceToken(p, t)),
        (pos, tok).prop_map(|(p, t)| Mutation::InsertToken(p, t)),
        pos.prop_map(Mutation::DuplicateToken),
        pos.prop_map(Mutation::Truncate),
    ]
}

/// Byte ranges of the whitespace-separated tokens of `src`.
fn token_spans(src: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < src.len() {
        if src[i].is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let s = i;
        while i < src.len() && !src[i].is_ascii_whitespace() {
            i += 1;
        }
        spans.push((s, i));
    }
    spans
}

fn apply(src: &mut Vec<u8>, m: &Mutation) {
    let n = src.len();
    let spans = token_spans(src);
    let span = |p: usize| spans.get(p % spans.len().max(1)).copied();
    match *m {
        Mutation::DeleteByte(p) if n > 0 => {
            src.remove(p % n);
        }
        Mutation::InsertByte(p, b) => src.insert(p % (n + 1), b),
        Mutation::ReplaceByte(p, b) if n > 0 => src[p % n] = b,
        Mutation::DeleteToken(p) => {
            if let Some((s, e)) = span(p) {
                src.drain(s..e);
            }
        }
        Mutation::ReplaceToken(p, t) => {
            if let Some((s, e)) = span(p) {
                src.splice(s..e, TOKENS[t].bytes());
            }
        }
        Mutation::InsertToken(p, t) => {
            let at = span(p).map_or(0, |(s, _)| s);
            let mut tok = TOKENS[t].as_bytes().to_vec();
            tok.push(b' ');
            src.splice(at..at, tok);
        }
        Mutation::DuplicateToken(p) => {
            if let Some((s, e)) = span(p) {
                let mut tok = src[s..e].to_vec();
                tok.push(b' ');
                src.splice(s..s, tok);
            }
        }
        Mutation::Truncate(p) => src.truncate(p % (n + 1)),
        _ => {}
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn damaged_spd_files_never_panic(
        which in 0usize..7,
        muts in prop::collection::vec(mutation(), 1..6),
    ) {
        let mut src = sources()[which].clone();
        for m in &muts {
            apply(&mut src, m);
        }
        let limits = Limits::default();
        let by_bytes = nff::parse_bytes(&src, "mutated.nff", &limits);
        // The &str entry point gives the same answer on valid UTF-8, and never panics on
        // lossily decoded text.
        match std::str::from_utf8(&src) {
            Ok(text) => prop_assert_eq!(
                nff::parse(text, "mutated.nff", &limits),
                by_bytes.clone().map(|p| p.description)
            ),
            Err(_) => {
                let _ = nff::parse(&String::from_utf8_lossy(&src), "mutated.nff", &limits);
            }
        }
        match by_bytes {
            Ok(parsed) => {
                let text = nff::to_nff(&parsed.description);
                let back = nff::parse(&text, "rewritten.nff", &limits);
                prop_assert_eq!(back.ok(), Some(parsed.description));
            }
            Err(e) => {
                prop_assert!(e.kind != NffErrorKind::Io);
                let lines = src.iter().filter(|&&b| b == b'\n').count() as u32 + 1;
                prop_assert!(e.line >= 1 && e.line <= lines, "line {} of {}: {}", e.line, lines, e);
                prop_assert!(e.column >= 1, "{}", e);
                prop_assert!(!e.message.is_empty());
            }
        }
    }
}

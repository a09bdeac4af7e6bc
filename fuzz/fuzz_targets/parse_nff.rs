//! Fuzz target: the NFF reader on arbitrary bytes must return `Ok` or `Err`, never panic, and
//! whatever it accepts must read back identically from the writer's output.
#![no_main]

use libfuzzer_sys::fuzz_target;
use parrt_render::nff::{self, Limits};

fuzz_target!(|data: &[u8]| {
    let limits = Limits::default();
    // The byte entry point, as `parse_file` uses it.
    if let Ok(parsed) = nff::parse_bytes(data, "fuzz.nff", &limits) {
        let text = nff::to_nff(&parsed.description);
        let back = nff::parse(&text, "rewritten.nff", &limits);
        assert_eq!(back.ok(), Some(parsed.description));
    }
    // The &str entry point, on valid UTF-8 as is and on anything else lossily decoded.
    match std::str::from_utf8(data) {
        Ok(s) => {
            let _ = nff::parse(s, "fuzz.nff", &limits);
        }
        Err(_) => {
            let _ = nff::parse(&String::from_utf8_lossy(data), "fuzz.nff", &limits);
        }
    }
});
